"""Warming up before a measure run: the arm by moving, the tracker by waiting.

A cold arm grows as its motors and gears warm, a cold tracker's distances
drift (a Leica AT960 needs about two hours after power-on; its warm-up errors
reach tenths of a millimetre). ``measure --warm-up MINUTES`` moves the arm
through the plan's own moves, without measuring, for about that long before
the first reading (:func:`warm_up`), and ``measure`` warns when the tracker
says it has not warmed up (:func:`tracker_warning`).

The warm-up runs the checked path forwards, then backwards, and so on: the
backward pass is the same joint-space segments in reverse, so every move it
makes is one the plan checks already passed (a jump from the last pose back to
the first would be a move nobody checked).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from calibrator.acquire import ports


def passes_for(minutes: float, pass_s: float) -> int:
    """Passes of the path (each ``pass_s`` s long) that last at least ``minutes`` (at least 1)."""
    if minutes <= 0:
        return 0
    return max(1, math.ceil(minutes * 60.0 / max(pass_s, 1e-9)))


def warm_up(
    robot: Any,
    path_rad: np.ndarray,
    passes: int,
    speed_rad_s: float,
    accel_rad_s2: float,
    should_stop: Callable[[], bool] = lambda: False,
) -> int:
    """Move through ``path_rad`` (M, 6) rad ``passes`` times, alternately forwards and backwards.

    Parameters
    ----------
    robot : calibrator.acquire.ports.Robot
    path_rad : ndarray, shape (M, 6)
        The plan's checked path (vias and poses in order), rad.
    passes : int
    speed_rad_s, accel_rad_s2 : float
        The run's own motion options.
    should_stop : callable
        Checked before every move; True ends the warm-up early.

    Returns
    -------
    int
        Moves made.
    """
    path = np.asarray(path_rad, dtype=float)
    moves = 0
    for k in range(passes):
        for q in path if k % 2 == 0 else path[::-1]:
            if should_stop():
                return moves
            robot.move_joints(q, speed_rad_s, accel_rad_s2)
            moves += 1
    return moves


def tracker_warning(tracker: Any) -> str | None:
    """A line when the tracker says it has not warmed up; None otherwise (or when it cannot say)."""
    if not ports.REPORTS_CONDITIONS.offered_by(tracker):
        return None
    try:
        said = tracker.conditions()
    except (ports.PortError, OSError):
        return None
    if not said or said.get("warmed_up") is not False:
        return None
    on = said.get("on_s")
    since = f" (on for {on / 60:.0f} min)" if on is not None else ""
    return (
        f"the tracker says it has not warmed up{since}: its distances drift by up to tenths "
        "of a millimetre until it has (about two hours after power-on for a Leica AT960); "
        "wait, or know that this session carries that drift"
    )


def warm_up_run(run: Any, minutes: float, should_stop: Callable[[], bool] = lambda: False) -> int:
    """:func:`warm_up` over a checked :class:`~calibrator.acquire.run.MeasureRun`'s plan.

    Runs as many passes of its path as last about ``minutes`` at the run's
    speed (the cell-time estimate of its moves); returns the passes.
    """
    o = run.options
    path = run.plan.path_rad
    passes = passes_for(minutes, run.estimate().moves_s)
    warm_up(run.robot, path, passes, o.speed_rad_s, o.accel_rad_s2, should_stop)
    return passes
