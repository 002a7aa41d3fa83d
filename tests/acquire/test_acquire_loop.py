"""The measure loop with real drivers: SimulatedRobot and the tracker simulator process.

Robot safety stops and a tracker link that drops and comes back, driven
in-process so the test can trip them at a chosen pose. Noise-free, so an
interrupted-and-resumed run must equal an uninterrupted one bit for bit.
"""

import contextlib

import numpy as np
import pytest

from calibrator.acquire import journal as journals
from calibrator.acquire import loop
from calibrator.acquire.averaging import AveragedReading, average, measure_average
from calibrator.acquire.ports import ReadingLost
from calibrator.simulate import SimWorld
from drivers.robot.errors import EmergencyStop
from drivers.robot.sim.device import SimulatedRobot
from drivers.tracker import LaserTracker
from drivers.tracker.line.simulator import SimulatorControl, SimulatorProcess

N_POSES = 10
HEADER = {"plan_sha256": "x", "robot": "sim", "tracker": "sim", "readings": 10}


@pytest.fixture(scope="module")
def cell():
    return SimWorld.make("ur10e", 0)


@pytest.fixture(scope="module")
def plan(checked_plan):
    # The shared plan's poses: a UR10e facing the simulated cell's tracker.
    assert len(checked_plan.q_rad) == N_POSES
    return checked_plan.q_rad


@contextlib.contextmanager
def rig(cell, socket=False):
    """Robot and tracker ports wired like the CLI's simulated cell (noise-free)."""
    with SimulatorProcess(noise=False, initialised=True) as sim:
        robot = SimulatedRobot(cell.true_mdh, cell.base2tracker, cell.flange2tool)
        robot.listener = lambda pose: sim.set_target(pose[:3, 3])
        # The TCP endpoint survives a hang-up (the pty does not): "lost and back".
        tracker = LaserTracker(sim.control_url if socket else sim.url)
        robot.connect()
        tracker.connect()
        try:
            yield robot, tracker, sim
        finally:
            tracker.close()
            robot.close()


def run(plan, robot, tracker, path, done=None, **kwargs):
    if done is None:
        journal = journals.Journal.create(path, HEADER)
    else:
        journal, resumed = journals.Journal.resume(path, HEADER)
        done = resumed.records
    with journal:
        return loop.run(plan, robot, tracker, journal, done=done, **kwargs)


@pytest.fixture(scope="module")
def reference(cell, plan, tmp_path_factory):
    with rig(cell) as (robot, tracker, _):
        out = run(plan, robot, tracker, tmp_path_factory.mktemp("ref") / "j")
    assert out.stopped is None and out.measured == list(range(N_POSES))
    return out.records


def assert_equal_records(records, reference):
    assert sorted(records) == sorted(reference)
    for pose, rec in records.items():
        for key in ("q_rad", "point_mm", "std_mm", "n_readings"):
            assert rec[key] == reference[pose][key], (pose, key)


class TrippingRobot:
    """SimulatedRobot whose safety system trips on the move to a given pose."""

    def __init__(self, robot, at, how):
        self.robot, self.at, self.how, self.moves = robot, at, how, 0

    def move_joints(self, q, speed, accel):
        if self.moves == self.at:
            getattr(self.robot, self.how)()
        self.moves += 1
        return self.robot.move_joints(q, speed, accel)

    def actual_joints(self):
        return self.robot.actual_joints()


@pytest.mark.parametrize("how", ["inject_protective_stop", "inject_emergency_stop"])
def test_safety_stop_ends_run_cleanly_then_clear_and_resume(cell, plan, reference, tmp_path, how):
    path = tmp_path / "j"
    with rig(cell) as (robot, tracker, _):
        out = run(plan, TrippingRobot(robot, 4, how), tracker, path)
        assert out.stopped.startswith("robot halted at pose 4")
        assert out.measured == [0, 1, 2, 3]
        assert sorted(journals.read(path).records) == [0, 1, 2, 3]
        # The operator's recovery: release the e-stop, clear the stop; then resume.
        if how == "inject_emergency_stop":
            with pytest.raises(EmergencyStop):
                robot.clear_protective_stop()
            robot.release_emergency_stop()
        robot.clear_protective_stop()
        resumed = run(plan, robot, tracker, path, done=True)
    assert resumed.stopped is None
    assert_equal_records(resumed.records, reference)


def test_tracker_link_lost_and_back_remeasures_the_pose(cell, plan, reference, tmp_path):
    with rig(cell, socket=True) as (robot, tracker, sim):
        control = SimulatorControl(sim.control_url)  # a second connection: survives the hang-up
        try:
            control.arm_fault("MEAS+35 hangup")  # 5th reading of pose 3
            out = run(plan, robot, tracker, tmp_path / "j")
        finally:
            control.close()
    assert out.stopped is None
    assert out.records[3]["attempts"] == 2 and out.records[2]["attempts"] == 1
    assert_equal_records(out.records, reference)


def test_stop_request_is_honoured_between_poses(cell, plan, reference, tmp_path):
    seen = []
    with rig(cell) as (robot, tracker, _):
        out = run(
            plan,
            robot,
            tracker,
            tmp_path / "j",
            should_stop=lambda: len(seen) >= 3,
            on_pose=seen.append,
        )
    assert out.stopped == "interrupted before pose 3" and out.measured == [0, 1, 2]
    assert [p.done for p in seen] == [1, 2, 3] and seen[-1].total == N_POSES


class _Reading:
    def __init__(self, point, accurate=True):
        self.point_mm, self.rotvec_rad, self.accurate = np.asarray(point, float), None, accurate


def test_average_leaves_out_flagged_readings_and_keeps_the_spread():
    readings = [_Reading([1, 2, 3]), _Reading([3, 2, 1]), _Reading([100, 0, 0], accurate=False)]
    avg = average(readings)
    assert isinstance(avg, AveragedReading)
    np.testing.assert_allclose(avg.mean_mm, [2, 2, 2])
    np.testing.assert_allclose(avg.std_mm, [np.sqrt(2), 0, np.sqrt(2)])
    assert (avg.count, avg.rejected, len(avg.readings)) == (2, 1, 3)


def test_a_lost_reading_never_yields_a_partial_average():
    class Breaks:
        def __init__(self):
            self.n = 0

        def measure(self, timeout_s=None):
            self.n += 1
            if self.n == 6:
                raise ReadingLost("beam broken")
            return _Reading([self.n, 0, 0])

    tracker = Breaks()
    with pytest.raises(ReadingLost):
        measure_average(tracker, 10)
    assert tracker.n == 6  # stopped at the lost reading; nothing averaged


def test_orientation_average_near_pi_agrees_with_scipy():
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(3)
    centre = Rotation.from_rotvec([0.0, np.pi - 1e-4, 0.0])  # a probe turned half a turn
    rots = centre * Rotation.from_rotvec(rng.normal(0.0, 2e-4, (10, 3)))
    readings = [_Reading([0, 0, 0]) for _ in range(10)]
    for r, rv in zip(readings, rots.as_rotvec(), strict=True):
        r.rotvec_rad = rv
    avg = average(readings)
    expected = rots.mean()
    np.testing.assert_allclose(
        Rotation.from_rotvec(avg.rotvec_mean_rad).as_matrix(), expected.as_matrix(), atol=1e-10
    )
    spread = (expected.inv() * rots).as_rotvec().std(axis=0, ddof=1)
    np.testing.assert_allclose(avg.rotvec_std_rad, spread, rtol=1e-4)
