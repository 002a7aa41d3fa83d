"""``MeasureRun`` over an arm running its own program: the arm never waits, no pose shifts.

The tracker here is scripted in time (not in calls): the reflector moves
through the plan's points and dwells at each, whether or not anyone reads
it, as with a controller running its program. Time is a simulated clock the
tracker and the watching share (each reading takes 2 ms of it, each sleep
passes as asked), so the run takes no wall-clock time and any pause of the
watching costs the stops the arm makes meanwhile, as it would in a cell.
"""

from __future__ import annotations

import numpy as np
import pytest

from calibrator import robots
from calibrator.acquire.external import ExternalOptions, ProgramArm, StopOptions
from calibrator.acquire.run import MeasureRun, RunOptions
from calibrator.errors import CalibrationError
from calibrator.model import frames, kinematics

MOVE_S, DWELL_S = 0.2, 0.6  # a 0.3 s settle window and 5 readings fit in the dwell
READING_S = 0.002  # a reading takes time
SKIPPED = 3
TOOL_MM = (0.0, 0.0, 100.0)  # the shared checked plan's reflector (tests/plan_kit.py)


class Clock:
    """Simulated seconds: advanced by sleeps and by the readings the tracker takes."""

    def __init__(self) -> None:
        self.t = 0.0

    def now(self) -> float:
        return self.t

    def sleep(self, seconds: float) -> None:
        self.t += max(float(seconds), 0.0)


class _Status:
    initialised = True


class _Reading:
    rotvec_rad = None
    accurate = True

    def __init__(self, point_mm, t: float):
        self.point_mm = point_mm
        self.device_time_us = int(t * 1e6)


class _ArmOnItsOwnClock:
    """A tracker seeing an arm that moves through ``points`` (tracker frame) by ``clock``.

    ``scale``: the program and the tracker's clock (its stamps) run that many
    times faster than ``clock``, as simulators run with ``--time-scale``.
    """

    capabilities: frozenset[str] = frozenset()
    device_id = "scripted:1"

    def __init__(self, points, clock: Clock, seed: int = 0, scale: float = 1.0):
        start = points.mean(axis=0)
        self.scale = scale
        self.stops = [start, *points, start]
        self.clock = clock
        self.rng = np.random.default_rng(seed)
        self.t0: float | None = None
        self.read = 0

    def connect(self):
        return _Status()

    def status(self):
        return _Status()

    def close(self) -> None:
        pass

    def measure(self, timeout_s=None):
        if self.t0 is None:  # the program starts when the run first looks
            self.t0 = self.clock.now()
        self.clock.sleep(READING_S)
        self.read += 1
        t = (self.clock.now() - self.t0) * self.scale
        leg, into = divmod(t, MOVE_S + DWELL_S)
        k = int(leg)
        if k + 1 >= len(self.stops):
            point = self.stops[-1]
        elif into < DWELL_S:
            point = self.stops[k]
        else:
            u = (into - DWELL_S) / MOVE_S
            point = self.stops[k] + (self.stops[k + 1] - self.stops[k]) * u
        return _Reading(point + self.rng.normal(0.0, 0.003, 3), t)


def _arm(clock: Clock, timeout_s: float = 5.0, cap: float = float("inf")) -> ProgramArm:
    stops = StopOptions(window_s=0.3, timeout_s=timeout_s)
    return ProgramArm("ur10e", cap, ExternalOptions(stops, clock=clock.now, sleep=clock.sleep))


def _run(tmp_path, plan, tracker, arm, **options):
    run_options = RunOptions(plan=plan, tool_mm=TOOL_MM, readings=5, **options)
    with MeasureRun(arm, tracker, robots.get("ur10e"), run_options, tmp_path / "s.parquet") as run:
        run.check_files()
        run.connect()
        run.make_plan()
        run.open_journal()
        run.measure()
        return run.finish()


def _points(plan):
    tool = frames.transform(translation=TOOL_MM)
    return kinematics.forward(robots.get("ur10e").mdh, plan.q_rad, tool)[:, :3, 3]


@pytest.mark.parametrize("scale", [1.0, 10.0])
def test_a_skipped_pose_costs_no_other_pose_even_with_retry_pauses(tmp_path, checked_plan, scale):
    """The plan's vias are no stops; pose 3 skipped is missing, every other pose is its own.

    With the program and the tracker's clock ten times faster than the host's,
    the run decides the same in a tenth of the time: it runs on the tracker's clock.
    """
    clock = Clock()
    points = np.delete(_points(checked_plan), SKIPPED, axis=0)
    tracker = _ArmOnItsOwnClock(points, clock, scale=scale)
    # Pauses of 0.7, 1.4 and 2.8 s before re-reading a lost pose: each longer than a dwell.
    summary = _run(tmp_path, checked_plan, tracker, _arm(clock), retry_pause_s=0.7)
    n = len(checked_plan.q_rad)
    assert summary.failed == [SKIPPED]
    assert summary.measured == [p for p in range(n) if p != SKIPPED]
    assert summary.notes[0] == f"missing: 1 pose(s) the program did not stop at: [{SKIPPED}]"
    # the run ends once the last pose is placed: the arm's move home, not a timeout
    assert clock.now() < ((n + 2) * (MOVE_S + DWELL_S) + 1.0) / scale


def test_a_program_that_ends_early_leaves_the_rest_missing_after_the_timeout(
    tmp_path, checked_plan
):
    clock = Clock()
    ran = 7  # the program is stopped after pose 6
    tracker = _ArmOnItsOwnClock(_points(checked_plan)[:ran], clock)
    summary = _run(tmp_path, checked_plan, tracker, _arm(clock, timeout_s=4.0))
    n = len(checked_plan.q_rad)
    assert summary.measured == list(range(ran))
    assert summary.failed == list(range(ran, n))
    assert summary.notes[0].endswith(f"did not stop at: {list(range(ran, n))}")
    # one timeout for the first pose missing, a short look for motion for each later one
    assert clock.now() < (ran + 2) * (MOVE_S + DWELL_S) + 4.0 + (n - ran) * 3 * 0.3 + 1.0


def test_a_plan_faster_than_the_arms_ceiling_is_refused_before_the_tracker_is_read(
    tmp_path, checked_plan
):
    clock = Clock()
    tracker = _ArmOnItsOwnClock(_points(checked_plan), clock)
    with pytest.raises(CalibrationError, match="above the ceiling 0.4 rad/s"):
        _run(tmp_path, checked_plan, tracker, _arm(clock, cap=0.4), speed_rad_s=0.5)
    assert tracker.read == 0
