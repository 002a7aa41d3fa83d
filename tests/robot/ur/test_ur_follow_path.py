"""A UR runs a timed joint path by servoJ and records its actual joints (RTDE).

The real ur-rtde client against the fake controller process (fixed ports,
machine-wide lock: the ``fake_ur`` fixture); the fake's own servoJ loop is
tested in-process.
"""

import time

import numpy as np
import pytest
from scipy.optimize import minimize_scalar
from timeout_kit import within

from calibrator import robots
from calibrator.acquire import ports
from drivers.robot.errors import LimitsViolation
from drivers.robot.options import RobotOptions
from drivers.robot.ur.device import UrRtdeRobot, open_url
from drivers.robot.ur.simulator.controller import (
    CMD_SERVO_STOP,
    CMD_SERVOJ,
    DONE,
    RUNTIME_PLAYING,
    FakeController,
)

#: The path of these tests: 1.2 s, every joint turning at most 0.2 rad/s.
T = np.linspace(0.0, 1.2, 301)
STEP = np.array([0.2, 0.1, -0.1, 0.05, 0.15, 0.1])


def lag_behind_command(stream, t, q):
    """The arm's lag behind the commanded timing, s (least squares over the record)."""
    host = stream.t_s + stream.host_offset_s - stream.start_host_s

    def sse(lag):
        at = np.stack([np.interp(host - lag, t, col) for col in q.T], axis=-1)
        return float(((at - stream.q_rad) ** 2).sum())

    return minimize_scalar(sse, bounds=(-0.1, 0.1), method="bounded").x


def test_the_fake_servoes_to_each_servoj_target_within_the_cycle_and_stops_on_servo_stop():
    c = FakeController()
    c.start_program()
    assert c.runtime_state == RUNTIME_PLAYING
    target = c.q + 0.01
    c.write_inputs(
        {"input_int_register_0": CMD_SERVOJ}
        | {f"input_double_register_{i}": v for i, v in enumerate(target)}
        | {"input_double_register_8": 0.004}
    )
    c.tick(0.002)
    np.testing.assert_allclose(c.q, target)
    assert c.moving and np.allclose(c.qd, 0.01 / 0.002)
    c.write_inputs({"input_int_register_0": CMD_SERVO_STOP})
    c.tick(0.002)
    assert c.out_int[0] == DONE and not c.moving
    np.testing.assert_allclose(c.q, target)  # it stays where the servo left it


def test_follow_path_runs_the_path_and_records_the_actual_joints_on_both_clocks(fake_ur):
    robot = UrRtdeRobot("127.0.0.1")
    robot.connect()
    try:
        q = robot.actual_joints() + np.outer(T / T[-1], STEP)
        start_us = robot.follow_path(T, q, delay_s=0.2)
        stream = within(robot.joint_stream, 30.0, "the path's end")
        np.testing.assert_allclose(robot.actual_joints(), q[-1], atol=1e-9)
    finally:
        robot.close()
    assert ports.FOLLOW_PATH.offered_by(robot)
    assert stream.start_host_s == pytest.approx(start_us / 1e6, abs=1e-6)
    host = stream.t_s + stream.host_offset_s - stream.start_host_s
    # From the hold before the motion to the hold after it, controller stamps rising.
    assert host[0] < 0.05 and host[-1] > T[-1] + 0.1 and np.all(np.diff(stream.t_s) > 0)
    np.testing.assert_allclose(stream.q_rad[0], q[0], atol=1e-9)
    np.testing.assert_allclose(stream.q_rad[-1], q[-1], atol=1e-9)
    # Samples in mid-path lie on the path (it is a straight line in joint space).
    mid = (host > 0.2) & (host < 1.0)
    u = (stream.q_rad[mid] - q[0]) @ STEP / (STEP @ STEP)
    np.testing.assert_allclose(stream.q_rad[mid], q[0] + np.outer(u, STEP), atol=1e-9)
    assert 0.1 < u.min() and u.max() < 0.9
    # The arm follows its servoJ set-points a cycle or a few late, never early.
    assert 0.0 <= lag_behind_command(stream, T, q) < 0.02


def test_a_path_over_the_speed_caps_is_refused_before_anything_moves(fake_ur):
    robot = open_url("ur://127.0.0.1", RobotOptions(robots.get("ur5e")))
    robot.connect()
    try:
        before = robot.actual_joints()
        q = before + np.outer(T / T[-1], STEP * 10)  # J1 at 1.67 rad/s, above its 1 rad/s cap
        with pytest.raises(LimitsViolation, match="joint J1 at 1.667 rad/s"):
            robot.follow_path(T, q, delay_s=0.2)
        np.testing.assert_allclose(robot.actual_joints(), before, atol=1e-9)
        assert fake_ur.command("fake moving") == "fake: moving false"
    finally:
        robot.close()


def test_the_move_to_a_paths_start_keeps_to_a_lowered_speed_cap(fake_ur):
    # --max-speed 0.3: the moveJ to the path's start (0.5 rad/s by default) is lowered to it.
    robot = open_url("ur://127.0.0.1", RobotOptions(robots.get("ur5e"), max_speed_rad_s=0.3))
    robot.connect()
    try:
        start = robot.actual_joints() + 0.05  # away from the arm: a lead-in is needed
        q = start + np.outer(T / T[-1], STEP)  # at most 0.17 rad/s along the path
        robot.follow_path(T, q, delay_s=0.2)
        stream = within(robot.joint_stream, 30.0, "the path's end")
    finally:
        robot.close()
    np.testing.assert_allclose(stream.q_rad[-1], q[-1], atol=1e-9)


def test_stop_ends_a_running_path_where_the_arm_is(fake_ur):
    robot = UrRtdeRobot("127.0.0.1")
    robot.connect()
    try:
        q = robot.actual_joints() + np.outer(T / T[-1], STEP)
        robot.follow_path(T, q, delay_s=0.1)
        time.sleep(0.6)  # mid-path
        robot.stop()
        stopped = robot.actual_joints()
        time.sleep(0.2)  # no set-point after the stop moves it on
        np.testing.assert_allclose(robot.actual_joints(), stopped, atol=1e-12)
        stream = within(robot.joint_stream, 30.0, "the path's end")
    finally:
        robot.close()
    u = (stopped - q[0]) @ STEP / (STEP @ STEP)
    assert 0.05 < u < 0.95  # stopped along the path, short of its end
    assert fake_ur.command("fake moving") == "fake: moving false"
    assert len(stream.t_s) > 10


def test_the_simulated_cell_pairs_the_urs_paths_with_the_tracker_and_only_the_urs():
    from calibrator.verify.path import StreamsJoints
    from drivers.devices import Devices
    from drivers.robot.ur.sim_cell import PathFollowing

    arm = robots.get("ur10e")
    ur = Devices("ur://127.0.0.1", "sim").open(arm, 3, None, None).robot  # nothing connects
    assert isinstance(ur, PathFollowing) and isinstance(ur, StreamsJoints)
    assert ports.FOLLOW_PATH.offered_by(ur) and ports.MOVES_HARDWARE in ur.capabilities
    sim = Devices("sim", "sim").open(arm, 3, None, None).robot
    assert not isinstance(sim, PathFollowing) and not isinstance(sim, StreamsJoints)
    assert ports.FOLLOW_PATH.offered_by(sim)  # its own path, tracker-only alignment
