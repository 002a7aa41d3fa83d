"""Hook the external robot into ``measure``'s rig (the robot registry's ``external`` entry)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from calibrator.errors import CalibrationError
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

    def view(tracker):
        if rig.sim_cell is not None:  # --tracker sim: nothing would ever move its target
            raise CalibrationError(
                "--robot external watches a tracker whose target a controller moves: give "
                "--tracker URL (a real tracker, or a tracker simulator the external-robot "
                "simulator steers; see docs/external-robots.md)"
            )
        return robot.readings_port(tracker)

    rig.tracker_view = view
    rig.summary = robot.summary
    return robot
