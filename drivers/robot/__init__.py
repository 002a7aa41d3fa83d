"""Robot link: one interface, a ``ur-rtde`` adapter, a simulated arm, safety checks.

See ``docs/robot-link.md``. Import the implementations from their modules
(``drivers.robot.ur_rtde_adapter``, ``drivers.robot.simulated``) so that the
simulated robot never needs the ``ur-rtde`` wheel.
"""

from drivers.robot.errors import (
    EmergencyStop,
    LimitsViolation,
    MotionFailed,
    ProtectiveStop,
)
from drivers.robot.interface import Robot, SafetyState
from drivers.robot.safety import GuardedRobot, MotionLimits, check_plan

__all__ = [
    "EmergencyStop",
    "GuardedRobot",
    "LimitsViolation",
    "MotionFailed",
    "MotionLimits",
    "ProtectiveStop",
    "Robot",
    "SafetyState",
    "check_plan",
]
