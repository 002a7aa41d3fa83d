"""The measure loop: move, settle, read N times, average, read back joints, journal the pose.

Domain logic over the two ports (:mod:`calibrator.acquire.ports`); the CLI
hands in concrete drivers. What happens on each failure:

- :class:`~calibrator.acquire.ports.ReadingLost` (beam break, unstable target,
  lost or garbled reply, link dropped and re-established): the pose's readings
  are all discarded and the pose is measured again, up to ``retries`` times,
  after a pause that doubles each time (``retry_pause_s``: a person or the
  tracker's own search can re-lock the beam meanwhile). Before a retry after
  a lost beam, a tracker that declares ``search`` looks for its reflector
  near the last point measured, and ``on_beam_lost`` (e.g. asking the
  operator to re-lock the beam) is called. After the retries the pose is
  journalled as failed, with its lost readings counted by failure class,
  and the run goes on; ``give_up_after`` failed poses in a row end it (the
  beam will not come back by itself).
- :class:`~calibrator.acquire.ports.RobotHalted` (protective stop, e-stop),
  :class:`~calibrator.acquire.ports.TrackerUnavailable`, or any other
  ``OSError`` (a lost robot link, a move that failed without a stop): the run
  ends cleanly; every finished pose is already in the journal.
- A stop request (SIGINT) is honoured between poses, never inside one.

Via poses (``via_rad``) are moved through, in order, before the pose they
precede; they are never measured nor counted, and pose numbers stay the
plan rows' indices.
"""

from __future__ import annotations

import re
import time
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from calibrator.acquire import rows
from calibrator.acquire.averaging import AveragedReading, measure_average
from calibrator.acquire.journal import Journal
from calibrator.acquire.ports import (
    SEARCH,
    BadReading,
    BeamLost,
    ReadingLost,
    Robot,
    RobotHalted,
    Tracker,
    TrackerUnavailable,
)


@dataclass(frozen=True)
class LoopOptions:
    """How each pose is measured.

    Attributes
    ----------
    readings : int
        Single readings per pose (10, the source paper's practice).
    settle_s : float
        Wait after the arm is steady before the first reading, s.
    retries : int
        Extra sets of readings after a lost one, per pose.
    speed_rad_s, accel_rad_s2 : float
        Leading-joint speed (rad/s) and acceleration (rad/s^2) of each move.
    retry_pause_s : float
        Pause before the first retry of a pose, s; doubled before each further
        one (at most 8 times this).
    give_up_after : int
        Failed poses in a row that end the run (0: never).
    """

    readings: int = 10
    settle_s: float = 0.0
    retries: int = 3
    speed_rad_s: float = 0.5
    accel_rad_s2: float = 1.0
    retry_pause_s: float = 0.0
    give_up_after: int = 0


@dataclass
class Progress:
    """What the loop reports after each pose (for a progress bar or log lines).

    Attributes
    ----------
    pose : int
        Plan row just finished.
    done : int
        Poses finished in this plan so far (measured or failed, resumed ones included).
    total : int
        Poses in the plan.
    record : dict
        The journal record just written.
    """

    pose: int
    done: int
    total: int
    record: dict


@dataclass
class Outcome:
    """How the run ended.

    Attributes
    ----------
    records : dict
        ``{pose: record}`` of every finished pose, from the journal and this run.
    stopped : str or None
        Why the run ended before the plan did (robot halted, tracker gone,
        interrupted); None when every pose was visited.
    """

    records: dict = field(default_factory=dict)
    stopped: str | None = None

    @property
    def measured(self) -> list[int]:
        return sorted(p for p, r in self.records.items() if r["status"] == "measured")

    @property
    def failed(self) -> list[int]:
        return sorted(p for p, r in self.records.items() if r["status"] == "failed")


@dataclass(frozen=True)
class Hooks:
    """What a run hands its acquisition besides the plan and options: resume state, callbacks.

    Attributes
    ----------
    done : dict
        ``{pose: record}`` already in the journal (resume).
    via_rad : sequence of N arrays of shape (k_i, 6), optional
        Via poses (rad) moved through before measured pose i.
    after_move, should_stop, on_pose, on_beam_lost : callables
        As for :func:`run`.
    """

    done: dict = field(default_factory=dict)
    via_rad: Sequence[np.ndarray] | None = None
    after_move: Callable[[np.ndarray], None] | None = None
    should_stop: Callable[[], bool] = lambda: False
    on_pose: Callable[[Progress], None] | None = None
    on_beam_lost: Callable[[int, int], None] | None = None


def run(
    plan_rad: ArrayLike,
    robot: Robot,
    tracker: Tracker,
    journal: Journal,
    options: LoopOptions = LoopOptions(),
    *,
    done: dict | None = None,
    after_move: Callable[[np.ndarray], None] | None = None,
    should_stop: Callable[[], bool] = lambda: False,
    on_pose: Callable[[Progress], None] | None = None,
    on_beam_lost: Callable[[int, int], None] | None = None,
    via_rad: Sequence[np.ndarray] | None = None,
    sleep: Callable[[float], None] = time.sleep,
) -> Outcome:
    """Measure every pose of a plan that is not finished yet.

    Parameters
    ----------
    plan_rad : array_like, shape (N, 6)
        Joint targets, rad, already validated whole (limits, speed cap, count).
    robot : calibrator.acquire.ports.Robot
        Connected.
    tracker : calibrator.acquire.ports.Tracker
        Connected.
    journal : calibrator.acquire.journal.Journal
        Open for appending; each finished pose is fsynced before the next move.
    options : LoopOptions
    done : dict, optional
        ``{pose: record}`` already in the journal (resume): measured poses are
        skipped, failed ones are tried again.
    after_move : callable, optional
        Called with the actual joints (rad, shape (6,)) once the arm is steady
        (a simulated world uses it to place the target).
    should_stop : callable
        Polled before each pose; True ends the run after the current pose.
    on_pose : callable, optional
        Called with a :class:`Progress` after each finished pose.
    on_beam_lost : callable, optional
        Called as ``on_beam_lost(pose, attempt)`` before a retry after a
        :class:`~calibrator.acquire.ports.BeamLost` (ask the operator to re-lock).
    via_rad : sequence of N arrays of shape (k_i, 6), optional
        Via poses (rad) moved through before measured pose i, already
        validated with the plan; an empty array for none.

    Returns
    -------
    Outcome
    """
    plan = np.asarray(plan_rad, dtype=float)
    state = _State(on_beam_lost, sleep)

    def one(pose: int) -> dict:
        if via_rad is not None:
            for via in np.asarray(via_rad[pose], dtype=float).reshape(-1, 6):
                robot.move_joints(via, options.speed_rad_s, options.accel_rad_s2)
        return _measure_pose(pose, plan[pose], robot, tracker, options, after_move, state)

    return drive(
        len(plan), one, journal, options, done=done, should_stop=should_stop, on_pose=on_pose
    )


def drive(
    poses: int,
    measure_pose: Callable[[int], dict],
    journal: Journal,
    options: LoopOptions = LoopOptions(),
    *,
    done: dict | None = None,
    should_stop: Callable[[], bool] = lambda: False,
    on_pose: Callable[[Progress], None] | None = None,
) -> Outcome:
    """Journal every pose not finished yet, however each is measured; end cleanly on failures.

    What every acquisition shares (a commanded robot's :func:`run`, an arm
    watched while it runs its own program): poses in plan order, measured
    ones skipped on resume, each record journalled before the next pose, a
    stop request honoured between poses, ``give_up_after`` failed poses in a
    row, and a clean end on a halted robot, a gone tracker or a lost link.

    Parameters
    ----------
    poses : int
        Poses in the plan (N); pose numbers are its rows 0..N-1.
    measure_pose : callable
        ``measure_pose(pose) -> record`` (:mod:`calibrator.acquire.rows`), measured or
        failed; raises :class:`~calibrator.acquire.ports.RobotHalted`,
        :class:`~calibrator.acquire.ports.TrackerUnavailable` or another ``OSError``
        to end the run.
    journal, options, done, should_stop, on_pose
        As for :func:`run`.

    Returns
    -------
    Outcome
    """
    outcome = Outcome(records=dict(done or {}))
    todo = [i for i in range(poses) if _pending(outcome.records.get(i))]
    in_row = 0
    for pose in todo:
        if should_stop():
            outcome.stopped = f"interrupted before pose {pose}"
            break
        try:
            record = measure_pose(pose)
        except RobotHalted as exc:
            outcome.stopped = f"robot halted at pose {pose}: {exc}"
            break
        except TrackerUnavailable as exc:
            outcome.stopped = f"tracker unavailable at pose {pose}: {exc}"
            break
        except OSError as exc:  # any other link or device failure: same clean end
            # a refused or unfinished move is no lost link: say which it was
            what = "link lost" if isinstance(exc, ConnectionError) else "failed"
            outcome.stopped = f"{what} at pose {pose}: {exc}"
            break
        journal.append(record)
        outcome.records[pose] = record
        if on_pose is not None:
            finished = sum(not _pending(r) for r in outcome.records.values())
            on_pose(Progress(pose, finished, poses, record))
        in_row = in_row + 1 if record["status"] == "failed" else 0
        if options.give_up_after and in_row >= options.give_up_after and pose != todo[-1]:
            outcome.stopped = (
                f"{in_row} poses in a row failed (last: pose {pose}, {_causes_text(record)}); "
                "check the beam and the reflector"
            )
            break
    return outcome


@dataclass
class _State:
    """What the loop carries from pose to pose: the last point measured, the callbacks."""

    on_beam_lost: Callable[[int, int], None] | None
    sleep: Callable[[float], None]
    last_point_mm: np.ndarray | None = None


def failure_class(exc: BaseException) -> str:
    """A failure class a user reads: ``BeamBroken`` -> ``beam broken``."""
    return re.sub(r"(?<!^)(?=[A-Z])", " ", type(exc).__name__).lower()


def _causes_text(record: dict) -> str:
    causes = record.get("causes") or {}
    return ", ".join(f"{what} x{n}" for what, n in causes.items()) or "no cause recorded"


def _pending(record: dict | None) -> bool:
    return record is None or record["status"] != "measured"


def _measure_pose(pose, target, robot, tracker, options, after_move, state: _State) -> dict:
    """One pose: move, settle, a full set of readings (re-taken whole if lost), joints."""
    actual = robot.move_joints(target, options.speed_rad_s, options.accel_rad_s2)
    if after_move is not None:
        after_move(np.asarray(actual, dtype=float))
    if options.settle_s > 0:
        state.sleep(options.settle_s)
    lost: list[str] = []
    causes: Counter = Counter()
    last_lost: ReadingLost | None = None
    for attempt in range(1, options.retries + 2):
        if last_lost is not None:
            _before_retry(pose, attempt, last_lost, tracker, options, state)
        try:
            avg = checked(measure_average(tracker, options.readings))
        except ReadingLost as exc:
            last_lost = exc
            lost.append(f"{type(exc).__name__}: {exc}")
            causes[failure_class(exc)] += 1
            continue
        # Read back after the readings: these are the joints the arm held while measured.
        q = robot.actual_joints()
        state.last_point_mm = avg.mean_mm
        return rows.measured_record(pose, q, avg, attempt, rows.conditions_of(robot, tracker))
    return rows.failed_record(pose, "; ".join(lost), options.retries + 1, dict(causes))


#: Largest coordinate or spread a reading may have, mm: no tracker reaches 1 km.
MAX_COORD_MM = 1e6


def checked(avg: AveragedReading) -> AveragedReading:
    """The averaged reading, or :class:`BadReading` if a number in it cannot be true.

    Whatever a driver let through (NaN, inf, 1e300 from a well-formed packet)
    is refused here, before it reaches the journal, as a lost reading.
    """
    values = [avg.mean_mm, avg.std_mm]
    if avg.rotvec_mean_rad is not None:
        values.append(avg.rotvec_mean_rad)
    for value in values:
        arr = np.asarray(value, dtype=float)
        if not (np.all(np.isfinite(arr)) and np.all(np.abs(arr) <= MAX_COORD_MM)):
            raise BadReading(f"reading with impossible numbers: {arr.tolist()}")
    return avg


def _before_retry(pose, attempt, exc, tracker, options, state: _State) -> None:
    """Back off, let the tracker search or the operator re-lock a lost beam, then retry."""
    if options.retry_pause_s > 0:
        state.sleep(options.retry_pause_s * min(2 ** (attempt - 2), 8))
    if not isinstance(exc, BeamLost):
        return
    if SEARCH.offered_by(tracker) and state.last_point_mm is not None:
        try:
            tracker.find_reflector(state.last_point_mm)
        except (ReadingLost, OSError):
            pass  # the search failed: the retry reports the beam as still lost
    if state.on_beam_lost is not None:
        state.on_beam_lost(pose, attempt)
