"""How a run gets its poses: a robot the loop commands, or an arm watched running its own program.

:class:`~calibrator.acquire.run.MeasureRun` picks one :class:`Acquisition`
for the robot it is handed (:func:`acquisition_for`) and otherwise does the
same for both: the whole-plan check, the journal, resume, the session file.

- :class:`Commanded`: the measure loop moves the robot to each pose (its
  vias first), settles, reads the tracker, reads back the joints
  (:func:`calibrator.acquire.loop.run`).
- :class:`calibrator.acquire.external.watched.Watched`: for a
  :class:`~calibrator.acquire.external.arm.ProgramArm` (``--robot external``),
  each pose is the stop the tracker saw the arm make there.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike

from calibrator.acquire import loop, ports
from calibrator.acquire.external.arm import ProgramArm
from calibrator.acquire.external.watched import Watched
from calibrator.acquire.journal import Journal


class Acquisition(Protocol):
    """What a run asks of the way its poses are measured."""

    def check_plan(
        self, plan_rad: np.ndarray, vias: Sequence[np.ndarray], options: loop.LoopOptions
    ) -> None:
        """Refuse (``ValueError``) a plan the robot's own limits forbid, before anything moves.

        ``plan_rad`` shape (N, 6) and the non-empty via arrays (k, 6), rad, run at
        ``options.speed_rad_s`` and ``options.accel_rad_s2``.
        """
        ...

    def measure(
        self, plan_rad: np.ndarray, journal: Journal, options: loop.LoopOptions, hooks: loop.Hooks
    ) -> loop.Outcome:
        """Measure every pose not finished yet (as :func:`calibrator.acquire.loop.run`)."""
        ...

    def notes(self) -> list[str]:
        """Lines for the end of the run (``Summary.notes``)."""
        ...


class Commanded:
    """The measure loop moves the robot to each pose and reads the tracker there.

    Parameters
    ----------
    robot : calibrator.acquire.ports.Robot
    tracker : calibrator.acquire.ports.Tracker
    """

    def __init__(self, robot: ports.Robot, tracker: ports.Tracker) -> None:
        self.robot, self.tracker = robot, tracker

    def check_plan(
        self, plan_rad: np.ndarray, vias: Sequence[np.ndarray], options: loop.LoopOptions
    ) -> None:
        """The robot's own check of every pose and via it will move to, when it has one."""
        robot = self.robot
        if ports.CHECKS_PLAN.offered_by(robot):
            motion = np.concatenate([plan_rad, *vias]) if vias else plan_rad
            robot.check_plan(motion, options.speed_rad_s, options.accel_rad_s2)

    def measure(
        self, plan_rad: np.ndarray, journal: Journal, options: loop.LoopOptions, hooks: loop.Hooks
    ) -> loop.Outcome:
        return loop.run(
            plan_rad,
            self.robot,
            self.tracker,
            journal,
            options,
            done=hooks.done,
            after_move=hooks.after_move,
            should_stop=hooks.should_stop,
            on_pose=hooks.on_pose,
            on_beam_lost=hooks.on_beam_lost,
            via_rad=hooks.via_rad,
        )

    def notes(self) -> list[str]:
        return []


def acquisition_for(
    robot: ports.Robot | ProgramArm, tracker: ports.Tracker, mdh: ArrayLike, tool_mm: ArrayLike
) -> Acquisition:
    """The strategy for ``robot``: watched for an arm running its own program, else commanded.

    ``mdh`` (6, 5; mm, rad) is the nominal arm and ``tool_mm`` (3,) the reflector
    guess on the flange, mm: a watched arm's stops are matched to where they put each pose.
    """
    if isinstance(robot, ProgramArm):
        return Watched(robot, tracker, mdh, tool_mm)
    return Commanded(robot, tracker)
