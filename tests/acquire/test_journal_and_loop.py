"""Journal records, session rows and the measure loop, called directly.

The journal itself is tested in test_journal.py.

The loop runs over scripted ports here (a robot that reports where it was
sent, a tracker that answers from a script), so each failure path can be
chosen exactly; test_acquire_loop.py runs the same loop over the real
simulator and simulated arm.
"""

import json
from datetime import UTC, datetime, timedelta

import numpy as np
import pytest

from calibrator import robots
from calibrator.acquire import loop, rows
from calibrator.acquire.averaging import TooFewReadings, average, measure_average
from calibrator.acquire.ports import (
    SEARCH,
    BeamLost,
    ReadingLost,
    RobotHalted,
    TrackerUnavailable,
)

HEADER = {"plan_sha256": "abc", "robot": "sim:r", "tracker": "t-1", "readings": 3, "poses": 4}


class Reading:
    def __init__(self, point, accurate=True, rotvec=None):
        self.point_mm = np.asarray(point, float)
        self.accurate = accurate
        self.rotvec_rad = None if rotvec is None else np.asarray(rotvec, float)
        self.device_time_us = 0


def averaged(points, rotvecs=None):
    rotvecs = rotvecs or [None] * len(points)
    return average([Reading(p, rotvec=r) for p, r in zip(points, rotvecs, strict=True)])


# ---------------------------------------------------------------- journal


# ---------------------------------------------------------------- records and rows


def test_a_measured_record_carries_the_average_joints_and_attempts():
    avg = average([Reading([1, 2, 3]), Reading([3, 2, 5]), Reading([9, 9, 9], accurate=False)])
    before = datetime.now(UTC)
    record = rows.measured_record(np.int64(7), (0.1, 0.2, 0.3, 0.4, 0.5, 0.6), avg, 2)
    stamp = datetime.fromisoformat(record.pop("timestamp"))
    assert before - timedelta(milliseconds=1) <= stamp <= datetime.now(UTC)
    assert record == {
        "pose": 7,
        "status": "measured",
        "q_rad": [0.1, 0.2, 0.3, 0.4, 0.5, 0.6],
        "point_mm": [2.0, 2.0, 4.0],
        "std_mm": [np.sqrt(2), 0.0, np.sqrt(2)],
        "n_readings": 2,
        "rejected": 1,
        "outliers": 0,
        "attempts": 2,
    }
    assert type(record["pose"]) is int and json.dumps(record)  # JSON-ready


def test_joints_are_recorded_as_floats_whatever_they_came_as():
    record = rows.measured_record(0, [0, 1, 0, 0, 0, 0], averaged([[0, 0, 0]]), 1)
    assert [type(v) for v in record["q_rad"]] == [float] * 6


def test_a_record_keeps_the_probe_orientation_when_there_is_one():
    avg = averaged([[0, 0, 0]] * 2, rotvecs=[[0.1, 0, 0], [0.1, 0, 0]])
    record = rows.measured_record(0, np.zeros(6), avg, 1)
    np.testing.assert_allclose(record["rotvec_rad"], [0.1, 0, 0], atol=1e-15)
    assert "rotvec_rad" not in rows.measured_record(0, np.zeros(6), averaged([[0, 0, 0]]), 1)


def test_a_failed_record():
    assert rows.failed_record(np.int64(3), "beam broken", 4) == {
        "pose": 3,
        "status": "failed",
        "reason": "beam broken",
        "attempts": 4,
    }


def record(pose, x, rotvec=None):
    rotvecs = None if rotvec is None else [rotvec, rotvec]
    avg = averaged([[x, 2 * x, 3 * x], [x + 1, 2 * x, 3 * x]], rotvecs)
    return rows.measured_record(pose, np.full(6, pose / 10), avg, 1)


IDENTITY = robots.JointConvention()


def test_session_rows_hold_the_controllers_angles_of_the_records_model_angles():
    kuka = robots.get("kuka-kr6-r900").convention
    table = rows.to_table([record(3, 10.0), record(4, 20.0)], kuka).to_pydict()
    written = np.array([[table[f"q{i}_rad"][k] for i in range(1, 7)] for k in range(2)])
    # The records hold the model's angles (3/10, 4/10 on every joint): A1 and A6 are mirrored.
    np.testing.assert_allclose(written[:, 0], [-0.3, -0.4])
    np.testing.assert_allclose(written[:, 5], [-0.3, -0.4])
    np.testing.assert_allclose(kuka.to_model(written), [[0.3] * 6, [0.4] * 6])


def test_session_rows_are_sorted_by_pose_with_gaps_where_poses_failed():
    records = [record(5, 50.0), rows.failed_record(1, "x", 2), record(0, 10.0), record(2, 20.0)]
    table = rows.to_table(records, IDENTITY).to_pydict()
    assert table["pose"] == [0, 2, 5]
    assert table["q1_rad"] == [0.0, 0.2, 0.5] and table["q6_rad"] == [0.0, 0.2, 0.5]
    assert table["x_mm"] == [10.5, 20.5, 50.5] and table["z_mm"] == [30.0, 60.0, 150.0]
    np.testing.assert_allclose(table["sx_mm"], [np.sqrt(0.5)] * 3)
    assert table["sy_mm"] == [0.0] * 3 and table["n_readings"] == [2, 2, 2]
    by_pose = {r["pose"]: r for r in records}
    assert table["timestamp"] == [by_pose[p]["timestamp"] for p in (0, 2, 5)]
    assert "rx_rad" not in table


def test_orientation_columns_only_when_every_pose_has_one():
    with_rot = [record(0, 1.0, [0, 0, 0.2]), record(1, 2.0, [0, 0.3, 0])]
    table = rows.to_table(with_rot, IDENTITY).to_pydict()
    np.testing.assert_allclose(table["rz_rad"], [0.2, 0.0], atol=1e-15)
    np.testing.assert_allclose(table["ry_rad"], [0.0, 0.3], atol=1e-15)
    assert "rx_rad" not in rows.to_table([*with_rot, record(2, 3.0)], IDENTITY).column_names


def test_no_measured_pose_makes_no_table():
    with pytest.raises(ValueError, match="^no measured poses$"):
        rows.to_table([rows.failed_record(0, "x", 1)], IDENTITY)


# ---------------------------------------------------------------- averaging


def test_the_default_minimum_is_half_the_readings_rounded_up():
    five = [Reading([i, 0, 0], accurate=i < 3) for i in range(5)]  # 3 of 5 accurate
    assert average(five).count == 3
    with pytest.raises(TooFewReadings, match="only 2 of 5 readings usable, need 3"):
        average([Reading([i, 0, 0], accurate=i < 2) for i in range(5)])
    with pytest.raises(TooFewReadings, match="need 4"):
        average(five, min_count=4)
    kept = average(five, reject_flagged=False)
    assert (kept.count, kept.rejected) == (5, 0) and kept.mean_mm[0] == 2.0
    single = average([Reading([1, 2, 3])])
    assert single.count == 1 and list(single.std_mm) == [0.0, 0.0, 0.0]
    with pytest.raises(TooFewReadings):
        average([Reading([0, 0, 0], accurate=False)], min_count=0)  # never an empty mean


def test_measure_average_takes_exactly_n_readings():
    class Counting:
        n = 0

        def measure(self, timeout_s=None):
            self.n += 1
            return Reading([self.n, 0, 0])

    tracker = Counting()
    avg = measure_average(tracker, 4, max_spread_mm=None)  # toy mm-scale spread
    assert tracker.n == 4 and avg.mean_mm[0] == 2.5 and len(avg.readings) == 4
    with pytest.raises(ValueError, match="n must be >= 1, got 0"):
        measure_average(tracker, 0)
    assert measure_average(Counting(), max_spread_mm=None).count == 10


# ---------------------------------------------------------------- the loop


class Arm:
    """Goes exactly where it is sent; can halt or lose its link at a chosen move."""

    def __init__(self, fail_at=None, error=None):
        self.q = np.zeros(6)
        self.moves, self.reads, self.fail_at, self.error = [], 0, fail_at, error

    def move_joints(self, q, speed, accel):
        if len(self.moves) == self.fail_at:
            raise self.error
        self.moves.append((np.array(q), speed, accel))
        self.q = np.array(q) + 1e-6  # where it really stopped
        return self.q

    def actual_joints(self):
        self.reads += 1
        return self.q + 1e-6  # a hair on after the readings


class Script:
    """A tracker answering from a list: a point, or an exception to raise."""

    capabilities = frozenset()

    def __init__(self, answers):
        self.answers, self.calls = list(answers), 0

    def measure(self, timeout_s=None):
        self.calls += 1
        answer = self.answers.pop(0) if self.answers else [1.0, 2.0, 3.0]
        if isinstance(answer, Exception):
            raise answer
        return Reading(answer)


class Journal:
    def __init__(self):
        self.lines = []

    def append(self, record):
        self.lines.append(record)


PLAN = np.arange(24, dtype=float).reshape(4, 6) / 10


def test_each_pose_is_moved_to_settled_measured_read_back_and_journalled():
    arm, tracker, journal, slept, placed, seen = Arm(), Script([]), Journal(), [], [], []
    options = loop.LoopOptions(
        readings=3, settle_s=0.25, retries=0, speed_rad_s=0.3, accel_rad_s2=0.7
    )
    out = loop.run(
        PLAN, arm, tracker, journal, options,
        after_move=placed.append, on_pose=seen.append, sleep=slept.append,
    )  # fmt: skip
    assert out.stopped is None and out.measured == [0, 1, 2, 3] and out.failed == []
    for (q, speed, accel), target in zip(arm.moves, PLAN, strict=True):
        np.testing.assert_array_equal(q, target)
        assert (speed, accel) == (0.3, 0.7)
    np.testing.assert_array_equal(placed, PLAN + 1e-6)  # the joints it stopped at
    assert slept == [0.25] * 4 and tracker.calls == 12 and arm.reads == 4
    assert journal.lines == [out.records[p] for p in range(4)]
    np.testing.assert_allclose(out.records[2]["q_rad"], PLAN[2] + 2e-6)  # read after measuring
    assert [(p.pose, p.done, p.total) for p in seen] == [(i, i + 1, 4) for i in range(4)]
    assert seen[1].record is out.records[1]


def test_no_wait_without_a_settle_time():
    slept = []
    loop.run(PLAN, Arm(), Script([]), Journal(), loop.LoopOptions(readings=1), sleep=slept.append)
    assert slept == []


def test_a_lost_set_is_taken_again_whole_and_given_up_after_the_retries():
    lost = ReadingLost("beam broken")
    answers = [[0, 0, 1], lost, [0, 0, 2.99], [0, 0, 3.01], *[lost] * 3, [5, 5, 5], [5, 5, 5]]
    journal = Journal()
    out = loop.run(
        PLAN[:3], Arm(), Script(answers), journal, loop.LoopOptions(readings=2, retries=2)
    )
    assert out.records[0]["attempts"] == 2 and out.records[0]["point_mm"] == [0.0, 0.0, 3.0]
    assert out.records[1] == {
        "pose": 1,
        "status": "failed",
        "reason": "; ".join(["ReadingLost: beam broken"] * 3),
        "attempts": 3,
        "causes": {"reading lost": 3},
    }
    assert out.records[2]["point_mm"] == [5.0, 5.0, 5.0]
    assert out.failed == [1] and out.measured == [0, 2] and out.stopped is None
    assert [r["pose"] for r in journal.lines] == [0, 1, 2]


@pytest.mark.parametrize(
    ("error", "stopped"),
    [
        (RobotHalted("protective stop"), "robot halted at pose 2: protective stop"),
        (TrackerUnavailable("gone"), "tracker unavailable at pose 2: gone"),
        (ConnectionResetError("reset"), "link lost at pose 2: reset"),
        (TimeoutError("move did not finish"), "failed at pose 2: move did not finish"),
    ],
)
def test_a_halt_or_a_lost_link_ends_the_run_keeping_the_finished_poses(error, stopped):
    journal = Journal()
    out = loop.run(PLAN, Arm(fail_at=2, error=error), Script([]), journal, loop.LoopOptions(3))
    assert out.stopped == stopped and out.measured == [0, 1]
    assert [r["pose"] for r in journal.lines] == [0, 1]


def test_a_lost_tracker_during_the_readings_ends_the_run():
    answers = [[1, 1, 1], TrackerUnavailable("cable")]
    out = loop.run(PLAN, Arm(), Script(answers), Journal(), loop.LoopOptions(readings=1))
    assert out.stopped == "tracker unavailable at pose 1: cable" and out.measured == [0]


def test_resume_skips_measured_poses_and_retries_failed_ones():
    done = {
        0: {"pose": 0, "status": "measured"},
        2: {"pose": 2, "status": "failed", "reason": "x", "attempts": 1},
    }
    arm, seen = Arm(), []
    out = loop.run(
        PLAN, arm, Script([]), Journal(), loop.LoopOptions(1), done=done, on_pose=seen.append
    )
    np.testing.assert_array_equal([m[0] for m in arm.moves], PLAN[1:])
    assert [(p.pose, p.done) for p in seen] == [(1, 2), (2, 3), (3, 4)]
    assert out.measured == [0, 1, 2, 3] and done[2]["status"] == "failed"  # input untouched


def test_a_stop_request_is_checked_before_each_pose():
    polls = []

    def stop():
        polls.append(1)
        return len(polls) > 2

    out = loop.run(PLAN, Arm(), Script([]), Journal(), loop.LoopOptions(1), should_stop=stop)
    assert out.stopped == "interrupted before pose 2" and out.measured == [0, 1]


def test_default_options_are_ten_readings_no_wait_three_retries():
    options = loop.LoopOptions()
    assert (options.readings, options.settle_s, options.retries) == (10, 0.0, 3)
    assert (options.speed_rad_s, options.accel_rad_s2) == (0.5, 1.0)
    tracker = Script([ReadingLost("x")] * 4)
    out = loop.run(PLAN[:1], Arm(), tracker, Journal())
    assert out.failed == [0] and tracker.calls == 4


class BeamBroken(BeamLost):
    """A tracker's own beam-lost error (its class name is the failure class)."""


class Searching(Script):
    """A tracker that can look for its reflector: records where it was asked to."""

    capabilities = frozenset({SEARCH})

    def __init__(self, answers):
        super().__init__(answers)
        self.searched = []

    def find_reflector(self, near_mm):
        self.searched.append(np.array(near_mm))


def test_a_lost_reading_is_retried_after_a_pause_that_doubles():
    slept = []
    answers = [ReadingLost("x")] * 4 + [[1, 1, 1]] * 4
    options = loop.LoopOptions(readings=1, retries=5, retry_pause_s=0.5)
    out = loop.run(PLAN[:1], Arm(), Script(answers), Journal(), options, sleep=slept.append)
    assert out.measured == [0] and out.records[0]["attempts"] == 5
    assert slept == [0.5, 1.0, 2.0, 4.0]  # before retries 1..4, none before the first try
    slept.clear()
    options = loop.LoopOptions(readings=1, retries=6, retry_pause_s=0.5)
    loop.run(PLAN[:1], Arm(), Script([ReadingLost("x")] * 7), Journal(), options,
             sleep=slept.append)  # fmt: skip
    assert slept == [0.5, 1.0, 2.0, 4.0, 4.0, 4.0]  # at most 8 times the first pause


def test_a_lost_beam_is_searched_for_near_the_last_point_and_the_operator_asked():
    tracker = Searching([[1, 2, 3], BeamBroken("beam"), ReadingLost("garbled"), [4, 5, 6]])
    asked = []
    out = loop.run(
        PLAN[:2], Arm(), tracker, Journal(), loop.LoopOptions(readings=1, retries=3),
        on_beam_lost=lambda pose, attempt: asked.append((pose, attempt)),
    )  # fmt: skip
    assert out.measured == [0, 1] and out.records[1]["attempts"] == 3
    np.testing.assert_array_equal(tracker.searched, [[1, 2, 3]])  # once: only after the beam
    assert asked == [(1, 2)]


def test_failed_poses_count_their_lost_readings_by_class():
    answers = [BeamBroken("a"), BeamBroken("b"), ReadingLost("c")]
    out = loop.run(PLAN[:1], Arm(), Script(answers), Journal(), loop.LoopOptions(1, retries=2))
    assert out.records[0]["causes"] == {"beam broken": 2, "reading lost": 1}
    assert loop.failure_class(TrackerUnavailable("x")) == "tracker unavailable"


def test_a_run_gives_up_after_failed_poses_in_a_row():
    options = loop.LoopOptions(readings=1, retries=1, give_up_after=2)
    tracker = Script([BeamBroken("x")] * 100)
    out = loop.run(PLAN, Arm(), tracker, Journal(), options)
    assert out.failed == [0, 1] and tracker.calls == 4
    assert out.stopped == (
        "2 poses in a row failed (last: pose 1, beam broken x2); check the beam and the reflector"
    )
    # A measured pose resets the count; the last pose never "gives up" the run.
    answers = [BeamBroken("x")] * 2 + [[1, 1, 1]] + [BeamBroken("x")] * 4
    out = loop.run(PLAN, Arm(), Script(answers), Journal(), options)
    assert out.failed == [0, 2, 3] and out.measured == [1] and out.stopped is None


def test_via_poses_are_moved_through_before_their_pose_and_never_measured():
    arm, tracker = Arm(), Script([])
    vias = [np.zeros((0, 6)), np.full((2, 6), 0.05), np.zeros((0, 6)), np.full((1, 6), -0.1)]
    out = loop.run(PLAN, arm, tracker, Journal(), loop.LoopOptions(readings=1), via_rad=vias)
    moved = np.array([m[0] for m in arm.moves])
    expected = np.vstack([PLAN[0], vias[1], PLAN[1], PLAN[2], vias[3], PLAN[3]])
    np.testing.assert_array_equal(moved, expected)
    assert out.measured == [0, 1, 2, 3] and tracker.calls == 4  # pose numbers are plan rows
    np.testing.assert_allclose(out.records[1]["q_rad"], PLAN[1] + 2e-6)


def test_readings_with_impossible_numbers_are_lost_never_journalled():
    answers = [[float("nan"), 0, 0], [1e300, 0, 0], [float("inf"), 0, 0], [1, 2, 3]]
    journal = Journal()
    out = loop.run(PLAN[:1], Arm(), Script(answers), journal, loop.LoopOptions(1, retries=3))
    assert out.measured == [0] and out.records[0]["attempts"] == 4
    assert journal.lines[0]["point_mm"] == [1.0, 2.0, 3.0]
    out = loop.run(PLAN[:1], Arm(), Script([[float("nan"), 0, 0]] * 2), Journal(),
                   loop.LoopOptions(1, retries=1))  # fmt: skip
    assert out.failed == [0] and out.records[0]["causes"] == {"impossible readings": 2}
