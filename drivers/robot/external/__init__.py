"""A robot that runs the plan as its own program while the tracker watches for its stops.

For any brand: load the program from ``calibrator program`` on the
controller, start it, and measure with ``--robot external``. See
``docs/external-robots.md``. Stop detection and association are domain
logic in :mod:`calibrator.acquire.external`.
"""

from drivers.robot.external.robot import ExternalRobot, PoseMissing

__all__ = ["ExternalRobot", "PoseMissing"]
