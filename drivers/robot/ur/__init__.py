"""Universal Robots arms: one brand's folder.

- :mod:`~drivers.robot.ur.device` -- :class:`UrRtdeRobot`, the robot interface through the
  ``ur-rtde`` client, and ``open_url`` (``ur://HOST``, behind the model's limits).
- :mod:`~drivers.robot.ur.simulator` -- a fake controller speaking RTDE, dashboard and
  script-port protocols on loopback (``python -m drivers.robot.ur.simulator``).

The ``ur-rtde`` wheel is imported only when a ``ur://`` robot is opened.
"""
