"""The robot registry's ``external`` entry: an arm running the plan as its own program.

Nothing here talks to the arm: the entry checks the URL and the cell, and
returns a :class:`calibrator.acquire.external.arm.ProgramArm`, for which
``MeasureRun`` watches the tracker (:mod:`calibrator.acquire.external`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from calibrator.acquire.external.arm import ExternalOptions, ProgramArm

if TYPE_CHECKING:
    from drivers.robot import RobotOptions


def open_external(url: str, options: RobotOptions) -> ProgramArm:
    """The ``external`` arm: the run watches its tracker for the stops of the arm's program.

    Parameters
    ----------
    url : str
        ``external`` (no host: there is no link to the arm).
    options : drivers.robot.RobotOptions
        ``model`` (nominal arm, speed ceiling), ``max_speed_rad_s`` (lowers the
        ceiling) and ``external`` (:class:`ExternalOptions`, optional).

    Raises
    ------
    ValueError
        A host was given, or the tracker is the embedded simulator (nothing
        would ever move its target).
    """
    if url != "external":
        raise ValueError(f"{url!r}: external takes no host (the arm runs its own program)")
    if options.world is not None:
        raise ValueError(
            "external watches a tracker whose target a controller moves: give --tracker URL "
            "(a real tracker, or a tracker simulator the external-robot simulator steers; "
            "see docs/external-robots.md)"
        )
    model = options.model
    cap = model.move_speed_cap_rad_s
    if options.max_speed_rad_s is not None:
        cap = min(cap, options.max_speed_rad_s)
    return ProgramArm(model.name, cap, options.external or ExternalOptions())
