"""A robot that runs the plan as its own program while the tracker watches for its stops.

For any brand: load the program from ``calibrator program`` on the
controller, start it, and measure with ``--robot external``. See
``docs/external-robots.md``.
"""

from drivers.robot.external.associate import Assigned, Associator, Rejected
from drivers.robot.external.robot import ExternalRobot, PoseMissing
from drivers.robot.external.stops import Stop, StopDetector, StopOptions

__all__ = [
    "Assigned",
    "Associator",
    "ExternalRobot",
    "PoseMissing",
    "Rejected",
    "Stop",
    "StopDetector",
    "StopOptions",
]
