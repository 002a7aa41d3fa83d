"""The simulated arm (``--robot sim``): one kind's folder.

- :mod:`~drivers.robot.sim.device` -- :class:`SimulatedRobot`, the "true" arm of the
  simulated cell, and ``open_url`` (``sim``, ``sim://?repeatability=typical|none``).
"""
