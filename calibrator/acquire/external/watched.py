"""The external acquisition: each pose is the stop the tracker saw the arm make there.

The strategy :class:`~calibrator.acquire.run.MeasureRun` picks for a
:class:`~.arm.ProgramArm`. Poses are journalled in plan order by the loop
every run shares (:func:`calibrator.acquire.loop.drive`); each pose's record
is the averaged readings of the stop matched to it (:mod:`.watch`), under the
plan's joints: the controller was told to go there and the tracker saw it
stop where that pose belongs. A pose without a stop is journalled as failed
at once, under its own number (no retry: the arm does not wait), so no pose
number shifts.

Vias are no stops: the controller moves through them in its own program, and
the run only checks them with the plan (cell, limits).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from calibrator.acquire import loop, rows
from calibrator.acquire.averaging import average
from calibrator.acquire.external.arm import ProgramArm
from calibrator.acquire.external.watch import Missing, PoseMissing, StopWatcher
from calibrator.acquire.journal import Journal
from calibrator.acquire.ports import ReadingLost, Tracker
from calibrator.model import kinematics


class Watched:
    """Measures a plan by watching the arm run it (see the module docstring).

    Parameters
    ----------
    arm : ProgramArm
    tracker : calibrator.acquire.ports.Tracker
        Connected by the run.
    mdh : array_like, shape (6, 5)
        Nominal MDH table (mm, rad) of the arm.
    tool_mm : array_like, shape (3,)
        Guessed reflector position on the flange, mm.
    """

    def __init__(self, arm: ProgramArm, tracker: Tracker, mdh: ArrayLike, tool_mm: ArrayLike):
        self.arm, self.tracker = arm, tracker
        self.mdh = np.asarray(mdh, dtype=float)
        self.tool_mm = np.asarray(tool_mm, dtype=float).reshape(3)
        self.watcher: StopWatcher | None = None

    def check_plan(
        self, plan_rad: np.ndarray, vias: Sequence[np.ndarray], options: loop.LoopOptions
    ) -> None:
        """Refuse a plan the program would run faster than the arm's ceiling (ValueError)."""
        speed, cap = options.speed_rad_s, self.arm.speed_cap_rad_s
        if not speed <= cap:
            raise ValueError(f"speed {speed} rad/s above the ceiling {cap} rad/s")

    def measure(
        self, plan_rad: np.ndarray, journal: Journal, options: loop.LoopOptions, hooks: loop.Hooks
    ) -> loop.Outcome:
        """Watch for every pose not finished yet; the loop journals each as it is decided.

        Of the ``hooks``, ``via_rad``, ``after_move`` and ``on_beam_lost`` are a
        commanded run's: the program moves through its vias itself, and a lost
        beam only restarts the settle window (nobody is asked to re-lock it: the
        arm does not wait).
        """
        plan = np.asarray(plan_rad, dtype=float)
        ext = self.arm.options
        self.watcher = watcher = StopWatcher(
            self.tracker,
            kinematics.forward(self.mdh, plan),  # (N, 4, 4), base frame
            self.tool_mm,
            options.readings,
            ext.stops,
            clock=ext.clock,
            sleep=ext.sleep,
            on_event=ext.log,
        )

        def one(pose: int) -> dict:
            found = watcher.wait_for(pose)
            if isinstance(found, Missing):
                return _failed(pose, PoseMissing(found.reason))
            try:
                avg = loop.checked(average(found.stop.readings, max_spread_mm="stated"))
            except ReadingLost as exc:
                return _failed(pose, exc)
            return rows.measured_record(pose, plan[pose], avg, 1)

        return loop.drive(
            len(plan),
            one,
            journal,
            options,
            done=hooks.done,
            should_stop=hooks.should_stop,
            on_pose=hooks.on_pose,
        )

    def notes(self) -> list[str]:
        """Lines for the end of the run: poses the program skipped, stops that matched none."""
        return [] if self.watcher is None else self.watcher.summary()


def _failed(pose: int, exc: ReadingLost) -> dict:
    return rows.failed_record(pose, f"{type(exc).__name__}: {exc}", 1, {loop.failure_class(exc): 1})
