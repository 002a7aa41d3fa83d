"""Robot link: one contract, robots opened by URL, a ``ur-rtde`` adapter, a simulated arm.

See ``docs/robot-link.md``. :func:`open_robot` builds the robot a URL names
(``sim``, ``ur://HOST``, or any scheme added with :func:`register_robot`);
the implementations are imported only when their scheme is used, so the
simulated robot never needs the ``ur-rtde`` wheel.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from drivers.robot.errors import (
    EmergencyStop,
    LimitsViolation,
    MotionFailed,
    ProtectiveStop,
)
from drivers.robot.interface import Robot, SafetyState
from drivers.robot.safety import GuardedRobot, MotionLimits, check_plan

if TYPE_CHECKING:
    from calibrator.acquire.external.arm import ProgramArm

__all__ = [
    "ROBOT_KINDS",
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


@dataclass(frozen=True)
class RobotOptions:
    """What a caller may ask of any robot kind when opening it.

    Attributes
    ----------
    model : calibrator.robots.RobotDescription
        The named arm (limits, data-sheet motion caps).
    world : calibrator.simulate.SimWorld, optional
        The simulated world (the ``sim`` kind needs it).
    max_speed_rad_s, max_accel_rad_s2 : float, optional
        Lower the model's fixed motion caps (never raise them).
    external : calibrator.acquire.external.arm.ExternalOptions, optional
        Stop detection and association of the ``external`` kind.
    """

    model: Any
    world: Any = None
    max_speed_rad_s: float | None = None
    max_accel_rad_s2: float | None = None
    external: Any = None


#: An opener builds a robot, or (``external``) an arm running its own program.
RobotOpener = Callable[[str, RobotOptions], "Robot | ProgramArm"]


def _open_sim(url: str, options: RobotOptions) -> Robot:
    from drivers.robot.simulated import SimulatedRobot

    world = options.world
    if world is None:
        raise ValueError("--robot sim needs the simulated world (measure builds it)")
    repeatability = world.repeatability
    robot = SimulatedRobot(
        world.true_mdh,
        world.base2tracker,
        world.flange2tool,
        repeatability=repeatability,
        rng=world.repeatability_rng() if repeatability is not None else None,
    )
    robot.device_id = f"sim:{world.model.name}:seed={world.seed}"
    return robot


def _open_ur(url: str, options: RobotOptions) -> Robot:
    from drivers import urls
    from drivers.robot.ur_rtde_adapter import UrRtdeRobot

    # The controller's ports are fixed (RTDE 30004, dashboard 29999): a host only.
    host = urls.parse(url, "ur", port="none").host
    limits = MotionLimits.from_model(
        options.model, options.max_speed_rad_s, options.max_accel_rad_s2
    )
    robot = GuardedRobot(UrRtdeRobot(host), limits)
    robot.device_id = f"ur://{host}:{options.model.name}"
    return robot


def _open_external(url: str, options: RobotOptions) -> ProgramArm:
    from drivers.robot.external.setup import open_external

    return open_external(url, options)


#: Robot kinds by URL scheme.
ROBOT_KINDS: dict[str, RobotOpener] = {"sim": _open_sim, "ur": _open_ur, "external": _open_external}
#: Kinds named by their bare scheme (no host).
_BARE_KINDS = ("sim", "external")


def register_robot(kind: str, opener: RobotOpener) -> None:
    """Add (or replace) the opener of URL scheme ``kind``."""
    ROBOT_KINDS[kind.lower()] = opener


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
    ValueError
        Unknown scheme (the message lists the known ones) or a missing host.
    """
    kind = url.split("://", 1)[0].lower() if "://" in url else url
    opener = ROBOT_KINDS.get(kind)
    if opener is None:
        raise ValueError(
            f"unknown robot {url!r}; use sim or "
            + ", ".join(f"{k}://HOST" for k in sorted(ROBOT_KINDS) if k not in _BARE_KINDS)
            + " or "
            + ", ".join(k for k in _BARE_KINDS if k != "sim")
        )
    return opener(url, options)
