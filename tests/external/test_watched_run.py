"""``MeasureRun`` over the ``external`` robot kind: the arm runs on its own clock, never waits.

The tracker here is scripted in time (not in calls): the reflector moves
through the plan's points and dwells at each, whether or not anyone reads
it, as with a controller running its program. A pose the program skipped
must cost no other pose: the run may not stop watching (a retry pause)
while the arm dwells at the next ones.
"""

from __future__ import annotations

import time

import numpy as np
from external_cell_kit import TOOL_MM, first_poses

from calibrator import plan as plans
from calibrator import robots
from calibrator.acquire import ports
from calibrator.acquire.run import MeasureRun, RunOptions
from calibrator.model import frames, kinematics
from drivers.robot import RobotOptions, open_robot
from drivers.robot.external.setup import ExternalOptions
from drivers.robot.external.stops import StopOptions

MOVE_S, DWELL_S = 0.2, 0.6  # a 0.3 s settle window and 5 readings fit in the dwell
SKIPPED = 3


class _Status:
    initialised = True


class _Reading:
    rotvec_rad = None
    accurate = True
    device_time_us = 0

    def __init__(self, point_mm):
        self.point_mm = point_mm


class _ArmOnItsOwnClock:
    """A tracker seeing an arm that moves through ``points`` by the wall clock (tracker frame)."""

    capabilities: frozenset[str] = frozenset()
    device_id = "scripted:1"

    def __init__(self, points, seed: int = 0):
        start = points.mean(axis=0)
        self.stops = [start, *points, start]
        self.rng = np.random.default_rng(seed)
        self.t0: float | None = None

    def connect(self):
        return _Status()

    def status(self):
        return _Status()

    def close(self) -> None:
        pass

    def measure(self, timeout_s=None):
        if self.t0 is None:  # the program starts when the run first looks
            self.t0 = time.monotonic()
        t = time.monotonic() - self.t0
        leg, into = divmod(t, MOVE_S + DWELL_S)
        k = int(leg)
        if k + 1 >= len(self.stops):
            point = self.stops[-1]
        elif into < DWELL_S:
            point = self.stops[k]
        else:
            u = (into - DWELL_S) / MOVE_S
            point = self.stops[k] + (self.stops[k + 1] - self.stops[k]) * u
        time.sleep(0.002)  # a reading takes time
        return _Reading(point + self.rng.normal(0.0, 0.003, 3))


def test_a_skipped_pose_costs_no_other_pose_even_with_retry_pauses(tmp_path, plan40):
    arm = robots.get("ur10e")
    # A plan the run's cell check passes (every pose and move clear of the cell),
    # as `calibrator plan` makes them: the first 14 poses of the shared one.
    tool_mm = TOOL_MM
    made = plans.read_plan(first_poses(plan40, 14, tmp_path / "plan.csv"))
    plan = made.q_rad
    tool = frames.transform(translation=tool_mm)
    points = kinematics.forward(arm.mdh, plan, tool)[:, :3, 3]
    tracker = _ArmOnItsOwnClock(np.delete(points, SKIPPED, axis=0))
    external = ExternalOptions(StopOptions(window_s=0.3, timeout_s=5.0), readings=5)
    robot = open_robot("external", RobotOptions(arm, tracker=tracker, external=external))
    assert {ports.WATCHES_TRACKER, ports.CHECKS_PLAN} <= robot.capabilities
    # Pauses of 0.7, 1.4 and 2.8 s between re-reads: each longer than a dwell.
    options = RunOptions(
        plan_rad=plan, via_rad=made.via_rad, tool_mm=tool_mm, readings=5, retry_pause_s=0.7
    )
    with MeasureRun(robot, tracker, arm, options, tmp_path / "s.parquet") as run:
        run.check_files()
        run.connect()
        run.make_plan()
        run.open_journal()
        run.measure()
        summary = run.finish()
    assert summary.failed == [SKIPPED]
    assert summary.measured == [p for p in range(len(plan)) if p != SKIPPED]
    assert summary.notes[0] == f"missing: 1 pose(s) the program did not stop at: [{SKIPPED}]"


class _Untouched:
    """A tracker that must not be read."""

    capabilities: frozenset[str] = frozenset()
    device_id = "untouched:1"

    def measure(self, timeout_s=None):
        raise AssertionError("a via move read the tracker")


def test_a_via_move_is_a_no_op_and_leaves_the_poses_in_order():
    arm = robots.get("ur10e")
    plan = np.random.default_rng(1).uniform(-1.0, 1.0, (6, 6))  # the robot checks speed only
    external = ExternalOptions(StopOptions(window_s=0.3, timeout_s=5.0), readings=5)
    robot = open_robot("external", RobotOptions(arm, tracker=_Untouched(), external=external))
    robot.check_plan(plan, arm.move_speed_cap_rad_s, arm.move_accel_cap_rad_s2)
    via = np.array([0.0, -np.pi / 2, 0.0, -np.pi / 2, 0.0, 0.0])
    start = time.monotonic()
    np.testing.assert_array_equal(robot.move_joints(via), via)
    assert time.monotonic() - start < 0.1  # no wait for a stop
    assert robot.missing == [] and robot._asked == -1  # no pose asked for, none missed
