"""The "robot" of a controller that runs the plan as its own program: it only watches.

:class:`ExternalRobot` satisfies the measure loop's robot port
(:class:`calibrator.acquire.ports.Robot`) without any link to the arm:

- ``move_joints(q)`` commands nothing. It watches the tracker until the stop
  that is pose ``q`` has been found and checked (:mod:`.stops`,
  :mod:`.associate`), taking the usual readings at each stop as it happens.
- ``actual_joints()`` returns the plan's joints of that pose: the controller
  was told to go there and the tracker saw it stop where that pose belongs.
- It declares :data:`~calibrator.acquire.ports.WATCHES_TRACKER`:
  :meth:`ExternalRobot.readings_port` wraps the tracker the loop measures
  with (``MeasureRun`` reads through it): for the pose just found it hands
  out the readings taken at its stop; for a pose the program skipped it
  raises :class:`PoseMissing` (a :class:`~calibrator.acquire.ports.ReadingLost`),
  so the loop journals that pose as failed under its own number and goes on. No pose number shifts.

Beam loss while the arm moves is expected: it only restarts the settle
window. A tracker that is gone (:class:`~calibrator.acquire.ports.TrackerUnavailable`)
ends the run as for any robot.
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from calibrator.acquire.ports import CHECKS_PLAN, WATCHES_TRACKER, ReadingLost
from calibrator.model import kinematics
from drivers.robot.errors import LimitsViolation
from drivers.robot.external.associate import Assigned, Associator, Rejected
from drivers.robot.external.stops import REARM_FACTOR, Stop, StopDetector, StopOptions
from drivers.robot.interface import Robot

#: After the program was taken as ended, each later pose first looks this many settle
#: windows for the arm moving again (a program restarted) before it is reported missing.
RECHECK_WINDOWS = 3


class PoseMissing(ReadingLost):
    """The program did not stop at this pose (skipped, or ended before it)."""


class ExternalRobot(Robot):
    """A robot port over a tracker watching an arm that runs its own program.

    Parameters
    ----------
    tracker : calibrator.acquire.ports.Tracker
        The tracker that watches the reflector (connected by the caller).
    mdh : array_like, shape (6, 5)
        Nominal MDH table (mm, rad) of the arm.
    flange2tool : ndarray, shape (4, 4)
        Guessed tool (reflector) frame on the flange, mm; read when the plan
        is handed over, so later in-place edits count.
    readings : int
        Readings taken at each stop (the loop averages them).
    options : StopOptions
    speed_cap_rad_s : float
        The model's speed ceiling; a plan run faster is refused.
    clock, sleep : callables
        Monotonic clock (s) and sleep, replaceable in tests.
    on_event : callable, optional
        Called with one line per stop decision (for a log).
    """

    #: It takes the plan before the first move, and the loop reads the tracker through it.
    capabilities: frozenset[str] = frozenset({CHECKS_PLAN, WATCHES_TRACKER})
    device_id: str = "external"

    def __init__(
        self,
        tracker: Any,
        mdh: ArrayLike,
        flange2tool: ArrayLike,
        readings: int,
        options: StopOptions | None = None,
        *,
        speed_cap_rad_s: float = float("inf"),
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
        on_event: Callable[[str], None] | None = None,
    ) -> None:
        self.tracker = tracker
        self.mdh = np.asarray(mdh, dtype=float)
        self.flange2tool = flange2tool
        self.readings = int(readings)
        self.options = options = options or StopOptions()
        self.speed_cap_rad_s = float(speed_cap_rad_s)
        self.clock, self.sleep = clock, sleep
        self.on_event = on_event
        self.plan: np.ndarray | None = None
        self.rejected: list[Rejected] = []
        self.missing: list[int] = []
        self.assigned: dict[int, Assigned] = {}
        self._assoc: Associator | None = None
        self._detector = StopDetector(options.band_mm, options.window_s)
        self._decided: deque[Assigned] = deque()
        self._stops = 0
        self._current: Assigned | None = None
        self._served = 0
        self._missing_now: str | None = None
        self._ended = False
        self._asked = -1
        # Readings this far apart (poll to poll) show the arm moving, mm.
        self._moving_mm = REARM_FACTOR * options.band_mm
        self._last_missing = -1

    # ------------------------------------------------------------ port

    def connect(self) -> str:
        return "external"

    def close(self) -> None:
        """Nothing to close: the arm is not ours."""

    def stop(self) -> None:
        """Nothing to stop: the controller runs its own program (use its stop button)."""

    def check_plan(self, q_rad: ArrayLike, speed_rad_s: float, accel_rad_s2: float) -> None:
        """Take the plan's measured poses (shape (N, 6), rad, in order) and check its speed.

        Only the measured poses: the stops are associated with these rows, and
        the vias the program moves through are no stops (the run checks them in
        the cell and against the limits).

        Raises
        ------
        LimitsViolation
            The speed is above the model's ceiling.
        """
        if not speed_rad_s <= self.speed_cap_rad_s:
            raise LimitsViolation(
                f"speed {speed_rad_s} rad/s above the ceiling {self.speed_cap_rad_s} rad/s"
            )
        self.plan = np.asarray(q_rad, dtype=float)

    def move_joints(
        self, q_rad: ArrayLike, speed_rad_s: float = 0.0, accel_rad_s2: float = 0.0
    ) -> np.ndarray:
        """Wait until pose ``q_rad`` (a row of the plan, rad) is found or known missing.

        A target that is no row of the plan is a via: the controller moves
        through it in its own program without stopping, so nothing is waited
        for and no stop is taken; it is returned as is.

        Returns
        -------
        numpy.ndarray, shape (6,)
            The plan's joints of that pose (or the via), rad.
        """
        if self._is_via(q_rad):
            return np.asarray(q_rad, dtype=float).copy()
        pose = self._pose_of(q_rad)
        if self._assoc is None:
            flange = kinematics.forward(self.mdh, self._plan)  # (N, 4, 4), base frame
            self._assoc = Associator(
                flange, np.asarray(self.flange2tool)[:3, 3], self.options.tolerance_mm, pose
            )
        self._current, self._served, self._missing_now = None, 0, None
        while True:
            while self._decided and self._decided[0].pose < pose:
                self._decided.popleft()  # a pose measured before a resume: not asked for again
            if self._decided:
                if self._decided[0].pose == pose:
                    self._current = self._decided.popleft()
                    break
                self._skip(
                    pose,
                    f"the program did not stop there (next stop was pose {self._decided[0].pose})",
                )
                break
            if self._ended:
                # Has the program been started again? A short look for motion first.
                if self._watch(RECHECK_WINDOWS * self.options.window_s):
                    self._ended = False
                    continue
                self._skip(
                    pose, f"no stop within {self.options.timeout_s:g} s (program ended or stopped)"
                )
                break
            self._watch(self.options.timeout_s)
        return self._plan[pose].copy()

    def actual_joints(self) -> np.ndarray:
        """The plan's joints of the pose just found (the arm stopped where it belongs), rad."""
        if self._current is None and self._missing_now is None:
            raise RuntimeError("actual_joints before a pose was found")
        pose = self._current.pose if self._current is not None else self._last_missing
        return self._plan[pose].copy()

    # ------------------------------------------------------------ readings

    def safety_state(self) -> object:
        """Unknown: the controller's safety system is not ours to read (its pendant shows it)."""
        return None

    def clear_protective_stop(self) -> None:
        """Nothing to clear from here: stops are cleared on the controller's pendant."""

    def readings_port(self, tracker: Any = None) -> _StopReadings:
        """The tracker port the measure loop reads: the current stop's readings.

        ``tracker`` (the raw tracker, optional) becomes the one this robot watches.
        """
        if tracker is not None:
            self.tracker = tracker
        return _StopReadings(self, self.tracker)

    def next_reading(self) -> Any:
        if self._missing_now is not None:
            raise PoseMissing(self._missing_now)
        if self._current is None:
            raise ReadingLost("no stop found for this pose")
        readings = self._current.stop.readings
        if self._served >= len(readings):
            raise ReadingLost("the arm left the pose: no more readings from its stop")
        self._served += 1
        return readings[self._served - 1]

    # ------------------------------------------------------------ summary

    def summary(self) -> list[str]:
        """Lines for the end of the run: missing poses and rejected stops."""
        lines = []
        if self.missing:
            lines.append(
                f"missing: {len(self.missing)} pose(s) the program did not stop at: "
                f"{self.missing[:20]}"
            )
        for r in self.rejected:
            lines.append(
                f"rejected stop {r.stop.number} at "
                f"{np.round(r.stop.point_mm, 2).tolist()} mm: {r.reason}"
            )
        return lines

    # ------------------------------------------------------------ inside

    @property
    def _associator(self) -> Associator:
        if self._assoc is None:
            raise RuntimeError("no plan yet: move_joints creates the associator")
        return self._assoc

    @property
    def _plan(self) -> np.ndarray:
        if self.plan is None:
            raise RuntimeError("check_plan(plan) must hand over the plan before the first move")
        return self.plan

    def _is_via(self, q_rad) -> bool:
        """True for a target that is no row of the measured plan (a via)."""
        return not np.all(self._plan == np.asarray(q_rad, dtype=float), axis=1).any()

    def _pose_of(self, q_rad) -> int:
        if self.plan is None:
            raise RuntimeError("check_plan(plan) must hand over the plan before the first move")
        hits = np.flatnonzero(np.all(self.plan == np.asarray(q_rad, dtype=float), axis=1))
        if not hits.size:
            raise ValueError("move target is not a row of the plan")
        # The loop asks for poses in plan order: a repeated row is the next one on.
        later = hits[hits > self._asked]
        self._asked = int(later[0] if later.size else hits[0])
        return self._asked

    def _skip(self, pose: int, why: str) -> None:
        self._missing_now = f"pose {pose} missing: {why}"
        self._last_missing = pose
        self.missing.append(pose)
        self._event(self._missing_now)

    def _event(self, line: str) -> None:
        if self.on_event is not None:
            self.on_event(line)

    def _decide(self, decisions) -> None:
        for d in decisions:
            if isinstance(d, Assigned):
                self.assigned[d.pose] = d
                self._decided.append(d)
                self._event(f"stop {d.stop.number} is pose {d.pose} (misfit {d.error_mm:.2f} mm)")
            else:
                self.rejected.append(d)
                self._event(f"stop {d.stop.number} rejected: {d.reason}")

    def _watch(self, budget_s: float) -> bool:
        """Read the tracker until a decision is made, or ``budget_s`` passes without a stop.

        Returns True when the arm was seen moving (or a stop was taken) meanwhile.
        At the end of a full ``timeout_s`` without a stop the last match is
        settled and, with still nothing decided, the program is taken as ended.
        """
        last_activity = self.clock()
        moved, previous = False, None
        while not self._decided:
            if self.clock() - last_activity > budget_s:
                if budget_s >= self.options.timeout_s:
                    self._decide(self._associator.finish())
                    self._ended = not self._decided
                return moved or bool(self._decided)
            try:
                reading = self.tracker.measure()
            except ReadingLost:  # beam lost while moving: expected
                self._detector.lost()
                self.sleep(self.options.poll_s)
                continue
            if not reading.accurate:
                self._detector.lost()
                continue
            point = np.asarray(reading.point_mm, dtype=float)
            if previous is not None and np.linalg.norm(point - previous) > self._moving_mm:
                moved = True
            previous = point
            centre = self._detector.add(self.clock(), point)
            if centre is not None:
                last_activity, moved = self.clock(), True
                stop = self._take(centre)
                if stop is not None:
                    self._decide(self._associator.add(stop))
                continue
            self.sleep(self.options.poll_s)
        return True

    def _take(self, centre) -> Stop | None:
        """The usual readings at a stop; None (a rejected stop) if the arm left during them."""
        taken = []
        try:
            for _ in range(self.readings):
                taken.append(self.tracker.measure())
        except ReadingLost as exc:
            self._reject_short(centre, f"a reading was lost at the stop ({exc})")
            return None
        points = np.array([r.point_mm for r in taken])
        if self._detector.left(points, centre):
            self._reject_short(centre, "the arm moved on during the readings (dwell too short)")
            return None
        number, self._stops = self._stops, self._stops + 1
        return Stop(number, self.clock(), points.mean(axis=0), tuple(taken))

    def _reject_short(self, centre, why: str) -> None:
        number, self._stops = self._stops, self._stops + 1
        self._detector.lost()
        self._decide([Rejected(Stop(number, self.clock(), np.asarray(centre)), why)])


class _StopReadings:
    """Tracker port for the loop: ``measure`` hands out the current stop's readings."""

    #: No search or steering through the view: a lost reading means "measure this pose
    #: again", which here means the stop's next readings.
    capabilities: frozenset[str] = frozenset()

    def __init__(self, robot: ExternalRobot, tracker):
        self._robot = robot
        self._tracker = tracker

    @property
    def device_id(self) -> str:
        return str(self._tracker.device_id)

    def connect(self):
        return self._tracker.connect()

    def status(self):
        return self._tracker.status()

    def measure(self, timeout_s: float | None = None):
        return self._robot.next_reading()

    def close(self) -> None:
        self._tracker.close()
