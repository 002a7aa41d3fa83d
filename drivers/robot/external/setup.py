"""Hook the external robot into ``measure``'s rig (the robot registry's ``external`` entry)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from drivers.robot.external.robot import ExternalRobot
from drivers.robot.external.stops import StopOptions


@dataclass(frozen=True)
class ExternalOptions:
    """What ``measure --robot external`` passes on.

    Attributes
    ----------
    stops : StopOptions
        Band, window, tolerance and timeout of the stop detection.
    readings : int
        Readings taken at each stop (``--readings``).
    log : callable, optional
        Receives one line per stop decision.
    """

    stops: StopOptions = field(default_factory=StopOptions)
    readings: int = 10
    log: Callable[[str], None] | None = None


def attach(rig, options: ExternalOptions | None = None) -> ExternalRobot:
    """Put an :class:`ExternalRobot` on ``rig`` (a :class:`calibrator.cli._hardware.Rig`).

    The robot watches whatever tracker the rig is given next: ``rig.tracker_view``
    hands the raw tracker to the robot and gives the loop the robot's view of
    it; ``rig.summary`` reports missing poses and rejected stops at the end.
    """
    options = options or ExternalOptions()
    robot = ExternalRobot(
        None,
        rig.model.mdh,
        rig.flange2tool_guess,  # the same array measure fills with --tool later
        options.readings,
        options.stops,
        speed_cap_rad_s=rig.model.move_speed_cap_rad_s,
        on_event=options.log,
    )
    rig.robot = robot
    rig.robot_id = f"external:{rig.model.name}"
    rig.tracker_view = robot.readings_port
    rig.summary = robot.summary
    return robot
