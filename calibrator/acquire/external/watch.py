"""Watching the tracker for the stops of an arm that runs the plan as its own program.

:class:`StopWatcher` reads the tracker port continuously, cuts the stream
into stops (:mod:`.stops`), takes the usual readings at each stop as it
happens and hands the stops to the association (:mod:`.associate`).
:meth:`StopWatcher.wait_for` answers, pose by pose in plan order, with the
stop that is that pose (:class:`~.associate.Assigned`) or why there is none
(:class:`Missing`: the program skipped it, or ended before it).

Everything is timed by the tracker's clock (:mod:`.clock`): the settle
window, the stop timeout and the pause between polls are tracker seconds.
Beam loss while the arm moves is expected: it only restarts the settle
window. A tracker that is gone (:class:`~calibrator.acquire.ports.TrackerUnavailable`)
propagates, and ends the run as for any robot.

Units: s, mm; stops in the tracker frame, flange poses in the robot base frame.
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from calibrator.acquire.external.associate import Assigned, Associator, Rejected
from calibrator.acquire.external.clock import TrackerClock
from calibrator.acquire.external.stops import REARM_FACTOR, Stop, StopDetector, StopOptions
from calibrator.acquire.ports import ReadingLost, Tracker

#: After the program was taken as ended, each later pose first looks this many settle
#: windows for the arm moving again (a program restarted) before it is reported missing.
RECHECK_WINDOWS = 3


class PoseMissing(ReadingLost):
    """The program did not stop at this pose (skipped, or ended before it)."""


@dataclass(frozen=True)
class Missing:
    """Plan pose ``pose`` has no stop; ``reason`` says why (one line)."""

    pose: int
    reason: str


class StopWatcher:
    """Finds the plan's poses, in plan order, among the stops the tracker sees.

    Parameters
    ----------
    tracker : calibrator.acquire.ports.Tracker
        The tracker that watches the reflector (connected by the caller).
    flange_poses : array_like, shape (N, 4, 4)
        Nominal flange poses of the plan's measured poses, robot base frame, mm.
    tool_mm : array_like, shape (3,)
        Guessed reflector position on the flange, mm (the association fits it).
    readings : int
        Readings taken at each stop (what the pose records).
    options : StopOptions
    clock, sleep : callables
        The host's monotonic clock (s) and sleep, replaceable in tests; the
        watching itself runs on the tracker's clock (:class:`TrackerClock`).
    on_event : callable, optional
        Called with one line per stop decision (for a log).
    """

    def __init__(
        self,
        tracker: Tracker,
        flange_poses: ArrayLike,
        tool_mm: ArrayLike,
        readings: int,
        options: StopOptions | None = None,
        *,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
        on_event: Callable[[str], None] | None = None,
    ) -> None:
        self.tracker = tracker
        self.flange = np.asarray(flange_poses, dtype=float)
        self.tool_mm = np.asarray(tool_mm, dtype=float).reshape(3)
        self.readings = int(readings)
        self.options = options = options or StopOptions()
        self.sleep = sleep
        self.clock = TrackerClock(clock)
        self.on_event = on_event
        self.rejected: list[Rejected] = []
        self.missing: list[int] = []
        self.assigned: dict[int, Assigned] = {}
        self._assoc: Associator | None = None
        self._detector = StopDetector(options.band_mm, options.window_s)
        self._decided: deque[Assigned] = deque()
        self._stops = 0
        self._ended = False
        # Readings this far apart (poll to poll) show the arm moving, mm.
        self._moving_mm = REARM_FACTOR * options.band_mm

    def wait_for(self, pose: int) -> Assigned | Missing:
        """Watch until plan pose ``pose`` is found or known missing.

        Poses are asked for in plan order; the first one asked is the first
        the association may place (a resumed run starts past its done poses).
        """
        if self._assoc is None:
            self._assoc = Associator(self.flange, self.tool_mm, self.options.tolerance_mm, pose)
        while True:
            while self._decided and self._decided[0].pose < pose:
                self._decided.popleft()  # a pose measured before a resume: not asked for again
            if self._decided:
                if self._decided[0].pose == pose:
                    return self._decided.popleft()
                return self._skip(
                    pose,
                    f"the program did not stop there (next stop was pose {self._decided[0].pose})",
                )
            if self._ended:
                # Has the program been started again? A short look for motion first.
                if self._watch(RECHECK_WINDOWS * self.options.window_s):
                    self._ended = False
                    continue
                return self._skip(
                    pose, f"no stop within {self.options.timeout_s:g} s (program ended or stopped)"
                )
            self._watch(self.options.timeout_s)

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
            raise RuntimeError("no pose asked for yet: wait_for creates the associator")
        return self._assoc

    def _skip(self, pose: int, why: str) -> Missing:
        missing = Missing(pose, f"pose {pose} missing: {why}")
        self.missing.append(pose)
        self._event(missing.reason)
        return missing

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
        At the end of a full ``timeout_s`` without a stop the stops seen are
        placed (the last match settled) and the program is taken as ended.
        """
        last_activity = self.clock.now()
        moved, previous = False, None
        while not self._decided:
            if self.clock.now() - last_activity > budget_s:
                if budget_s >= self.options.timeout_s:
                    # Taken as ended even when the stops seen are only now placed: the
                    # poses after them are looked for briefly, not a whole timeout each.
                    self._decide(self._associator.finish())
                    self._ended = True
                return moved or bool(self._decided)
            try:
                reading = self.tracker.measure()
            except ReadingLost:  # beam lost while moving: expected
                self._detector.lost()
                self.sleep(self.clock.host_seconds(self.options.poll_s))
                continue
            if not reading.accurate:
                self._detector.lost()
                continue
            point = np.asarray(reading.point_mm, dtype=float)
            if previous is not None and np.linalg.norm(point - previous) > self._moving_mm:
                moved = True
            previous = point
            now = self.clock.stamp(reading.device_time_us)
            centre = self._detector.add(now, point)
            if centre is not None:
                last_activity, moved = now, True
                stop = self._take(centre)
                if stop is not None:
                    self._decide(self._associator.add(stop))
                continue
            self.sleep(self.clock.host_seconds(self.options.poll_s))
        return True

    def _take(self, centre) -> Stop | None:
        """The usual readings at a stop; None (a rejected stop) if the arm left during them."""
        taken = []
        try:
            for _ in range(self.readings):
                taken.append(self.tracker.measure())
                self.clock.stamp(taken[-1].device_time_us)
        except ReadingLost as exc:
            self._reject_short(centre, f"a reading was lost at the stop ({exc})")
            return None
        points = np.array([r.point_mm for r in taken])
        if self._detector.left(points, centre):
            self._reject_short(centre, "the arm moved on during the readings (dwell too short)")
            return None
        number, self._stops = self._stops, self._stops + 1
        return Stop(number, self.clock.now(), points.mean(axis=0), tuple(taken))

    def _reject_short(self, centre, why: str) -> None:
        number, self._stops = self._stops, self._stops + 1
        self._detector.lost()
        self._decide([Rejected(Stop(number, self.clock.now(), np.asarray(centre)), why)])
