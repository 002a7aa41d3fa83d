"""Errors of the robot link, derived from the drivers' one tree (:mod:`drivers.errors`).

=====================  ==========================================================
:class:`ProtectiveStop`  safety system stopped the arm (collision, limit); needs a clear
:class:`EmergencyStop`   an e-stop is engaged
:class:`MotionFailed`    a move ended without reaching its target (stopped, refused)
:class:`LimitsViolation` a plan or move was refused before motion by the safety checks
=====================  ==========================================================

Connection problems are :class:`~drivers.errors.ConnectionLost`, missed deadlines
:class:`~drivers.errors.DriverTimeout`, wrong state :class:`~drivers.errors.NotReady`.
"""

from calibrator.acquire.ports import RobotHalted
from drivers.errors import ConnectionLost, DriverError, DriverTimeout, NotReady, ProtocolError

__all__ = [
    "ConnectionLost",
    "DriverError",
    "DriverTimeout",
    "EmergencyStop",
    "LimitsViolation",
    "MotionFailed",
    "NotReady",
    "ProtectiveStop",
    "ProtocolError",
]


class ProtectiveStop(NotReady, RobotHalted):
    """The arm is protective-stopped; no move is accepted until it is cleared."""


class EmergencyStop(NotReady, RobotHalted):
    """An emergency stop is engaged; an operator must release it."""


class MotionFailed(DriverError):
    """A move did not reach its target (stopped early, refused by the controller)."""


class LimitsViolation(DriverError, ValueError):
    """A target or motion parameter is outside the allowed limits; nothing was moved.

    Attributes
    ----------
    pose_index : int or None
        Row of the plan that violates (0-based), ``None`` for a parameter.
    joint_index : int or None
        Joint that violates (0-based: 0 is joint 1), ``None`` for a parameter.
    """

    def __init__(
        self, message: str, pose_index: int | None = None, joint_index: int | None = None
    ) -> None:
        super().__init__(message)
        self.pose_index = pose_index
        self.joint_index = joint_index
