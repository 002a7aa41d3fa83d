"""The robot registry's ``external`` entry: an :class:`ExternalRobot` over its tracker."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from calibrator.model import frames
from calibrator.simulate import DEFAULT_TOOL_POINT
from drivers.robot.external.robot import ExternalRobot
from drivers.robot.external.stops import StopOptions

if TYPE_CHECKING:
    from drivers.robot import RobotOptions


@dataclass(frozen=True)
class ExternalOptions:
    """What ``measure --robot external`` passes on (``RobotOptions.external``).

    Attributes
    ----------
    stops : StopOptions
        Band, window, tolerance and timeout of the stop detection.
    readings : int
        Readings taken at each stop (``--readings``).
    tool_mm : tuple of 3 float
        First guess of the reflector on the flange (``--tool``), mm: stops are
        matched to the poses where this point would be.
    log : callable, optional
        Receives one line per stop decision.
    """

    stops: StopOptions = field(default_factory=StopOptions)
    readings: int = 10
    tool_mm: tuple[float, float, float] = tuple(DEFAULT_TOOL_POINT)  # type: ignore[assignment]
    log: Callable[[str], None] | None = None


def open_external(url: str, options: RobotOptions) -> ExternalRobot:
    """The ``external`` robot: watches ``options.tracker`` for the stops of the arm's program.

    Parameters
    ----------
    url : str
        ``external`` (no host: there is no link to the arm).
    options : drivers.robot.RobotOptions
        ``model`` (nominal arm, speed ceiling), ``tracker`` (the raw tracker,
        required) and ``external`` (:class:`ExternalOptions`, optional).

    Raises
    ------
    ValueError
        A host was given, no tracker was handed over, or the tracker is the
        embedded simulator (nothing would ever move its target).
    """
    if url != "external":
        raise ValueError(f"{url!r}: external takes no host (the arm runs its own program)")
    if options.world is not None:
        raise ValueError(
            "external watches a tracker whose target a controller moves: give --tracker URL "
            "(a real tracker, or a tracker simulator the external-robot simulator steers; "
            "see docs/external-robots.md)"
        )
    if options.tracker is None:
        raise ValueError("external needs the tracker it watches (RobotOptions.tracker)")
    ext = options.external or ExternalOptions()
    model = options.model
    cap = model.move_speed_cap_rad_s
    if options.max_speed_rad_s is not None:
        cap = min(cap, options.max_speed_rad_s)
    robot = ExternalRobot(
        options.tracker,
        model.mdh,
        frames.transform(translation=[float(v) for v in ext.tool_mm]),
        ext.readings,
        ext.stops,
        speed_cap_rad_s=cap,
        on_event=ext.log,
    )
    robot.device_id = f"external:{model.name}"
    return robot
