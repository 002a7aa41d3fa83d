"""Robot link: one contract, robots opened by URL, a ``ur-rtde`` adapter, a simulated arm.

See ``docs/robot-link.md``. :func:`open_robot` builds the robot a URL names
(``sim``, ``ur://HOST``, or any scheme added with :func:`register_robot`;
registry: :data:`ROBOTS`); the implementations are imported only when their scheme is used, so the
simulated robot never needs the ``ur-rtde`` wheel.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from drivers.registry import Registry
from drivers.robot.errors import (
    EmergencyStop,
    LimitsViolation,
    MotionFailed,
    ProtectiveStop,
)
from drivers.robot.interface import Robot, SafetyState
from drivers.robot.options import RobotOptions
from drivers.robot.safety import GuardedRobot, MotionLimits, check_plan

if TYPE_CHECKING:
    from calibrator.acquire.external.arm import ProgramArm

__all__ = [
    "ROBOTS",
    "RobotOptions",
    "open_robot",
    "register_robot",
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


#: Robot kinds by URL scheme (:mod:`drivers.registry`): each module opens its
#: URLs with ``open_url(url, options)``.
#: ``external`` gives an arm running its own program, which the run watches.
ROBOTS: Registry[Robot | ProgramArm, RobotOptions] = Registry("robot", bare=("sim", "external"))
ROBOTS.register("sim", "drivers.robot.sim.device")
ROBOTS.register("ur", "drivers.robot.ur.device", usage="ur://HOST")
ROBOTS.register("external", "drivers.robot.external.setup:open_external")


def register_robot(
    kind: str,
    handler: str | Callable[[str, RobotOptions], Robot | ProgramArm],
    usage: str | None = None,
) -> None:
    """Add (or replace) the handler of URL scheme ``kind`` (:class:`drivers.registry.Registry`)."""
    ROBOTS.register(kind, handler, usage)


def open_robot(url: str, options: RobotOptions) -> Robot | ProgramArm:
    """The robot named by ``url``, not yet connected, with a ``device_id`` for the journal.

    Parameters
    ----------
    url : str
        ``sim``, ``ur://HOST``, ``external`` (an arm running the plan as its
        own program, which the run watches through its tracker), or a
        registered scheme.
    options : RobotOptions

    Returns
    -------
    drivers.robot.interface.Robot or calibrator.acquire.external.arm.ProgramArm
        Every move of a robot that moves hardware is checked against the
        model's limits first (:class:`GuardedRobot`); ``external`` gives a
        :class:`~calibrator.acquire.external.arm.ProgramArm` (nothing to command).

    Raises
    ------
    drivers.registry.UnknownKind
        Unknown scheme (a ``ValueError``; the message lists the known ones).
    ValueError
        The URL does not suit its kind (a missing host, a parameter it does not take).
    """
    return ROBOTS.open(url, options)
