"""One behavioural suite for the robot interface, run on every implementation.

``harness`` (tests/robot/conftest.py) yields the simulated robot and the
ur-rtde adapter talking to the fake controller in its own process (the
``fake_ur`` fixture): the suite's scheduler (tests/conftest.py) runs this
module with the other fake-UR modules, one after another on one worker,
instead of leaving the other worker waiting for the fake's ports.
"""

import numpy as np
import pytest

from drivers.errors import DriverError, NotReady
from drivers.robot.errors import EmergencyStop, LimitsViolation, ProtectiveStop
from drivers.robot.interface import SafetyState
from drivers.robot.safety import GuardedRobot, MotionLimits

SPEED, ACCEL = 1.0, 2.0
STEP = np.array([0.05, -0.04, 0.03, 0.02, -0.05, 0.06])  # rad, a small move in every joint


def test_connects_reads_joints_and_safety(harness):
    with harness.robot as robot:
        q = robot.actual_joints()
        assert q.shape == (6,)
        assert np.all(np.isfinite(q))
        assert robot.safety_state() == SafetyState(False, False)
        assert robot.safety_state().ok


def test_move_reaches_target_and_reads_back(harness):
    with harness.robot as robot:
        start = robot.actual_joints()
        target = start + STEP
        reached = robot.move_joints(target, SPEED, ACCEL)
        np.testing.assert_allclose(reached, target, atol=harness.tolerance_rad)
        np.testing.assert_allclose(robot.actual_joints(), target, atol=harness.tolerance_rad)
        # and back: the second move starts from where the first ended
        back = robot.move_joints(start, SPEED, ACCEL)
        np.testing.assert_allclose(back, start, atol=harness.tolerance_rad)


def test_stop_when_idle_keeps_the_arm_and_reconnect_works(harness):
    with harness.robot as robot:
        start = robot.move_joints(robot.actual_joints() + STEP, SPEED, ACCEL)
        robot.stop()
        np.testing.assert_allclose(robot.actual_joints(), start, atol=harness.tolerance_rad)
    with harness.robot as robot:  # a closed robot connects again where it was left
        np.testing.assert_allclose(robot.actual_joints(), start, atol=harness.tolerance_rad)
        robot.move_joints(start - STEP, SPEED, ACCEL)


def test_protective_stop_refuses_moves_until_cleared(harness):
    with harness.robot as robot:
        start = robot.actual_joints()
        harness.inject_protective_stop()
        assert robot.safety_state().protective_stopped
        with pytest.raises(ProtectiveStop):
            robot.move_joints(start + STEP, SPEED, ACCEL)
        np.testing.assert_allclose(robot.actual_joints(), start, atol=harness.tolerance_rad)
        robot.clear_protective_stop()
        assert robot.safety_state().ok
        reached = robot.move_joints(start + STEP, SPEED, ACCEL)
        np.testing.assert_allclose(reached, start + STEP, atol=harness.tolerance_rad)


def test_unlock_elsewhere_does_not_lift_the_drivers_refusal(harness):
    # an operator clearing the stop on the pendant must not let a plan resume on its own
    with harness.robot as robot:
        start = robot.actual_joints()
        harness.inject_protective_stop()
        harness.unlock_from_pendant()
        assert robot.safety_state().ok
        with pytest.raises(ProtectiveStop):
            robot.move_joints(start + STEP, SPEED, ACCEL)
        robot.clear_protective_stop()
        robot.move_joints(start + STEP, SPEED, ACCEL)


def test_emergency_stop_needs_release_before_clear(harness):
    with harness.robot as robot:
        start = robot.actual_joints()
        harness.inject_emergency_stop()
        assert robot.safety_state().emergency_stopped
        with pytest.raises(EmergencyStop):
            robot.move_joints(start + STEP, SPEED, ACCEL)
        with pytest.raises(EmergencyStop):
            robot.clear_protective_stop()
        harness.release_emergency_stop()
        robot.clear_protective_stop()
        reached = robot.move_joints(start + STEP, SPEED, ACCEL)
        np.testing.assert_allclose(reached, start + STEP, atol=harness.tolerance_rad)


@pytest.mark.parametrize(
    "bad",
    [
        dict(q=np.zeros(5), speed=SPEED, accel=ACCEL),
        dict(q=np.full(6, np.nan), speed=SPEED, accel=ACCEL),
        dict(q=None, speed=0.0, accel=ACCEL),
        dict(q=None, speed=SPEED, accel=-1.0),
    ],
)
def test_bad_arguments_raise_before_moving(harness, bad):
    with harness.robot as robot:
        start = robot.actual_joints()
        q = start + STEP if bad["q"] is None else bad["q"]
        with pytest.raises(ValueError):
            robot.move_joints(q, bad["speed"], bad["accel"])
        np.testing.assert_allclose(robot.actual_joints(), start, atol=harness.tolerance_rad)


def test_not_connected_is_not_ready(harness):
    robot = harness.robot
    with pytest.raises(NotReady):
        robot.actual_joints()
    with pytest.raises(NotReady):
        robot.move_joints(np.zeros(6), SPEED, ACCEL)
    with robot:
        robot.actual_joints()
    with pytest.raises(NotReady):
        robot.actual_joints()  # closed again by the context manager


def test_guarded_robot_refuses_out_of_limit_target_without_moving(harness):
    limits = MotionLimits(
        np.tile([-np.pi, np.pi], (6, 1)), max_speed_rad_s=1.5, max_accel_rad_s2=3.0
    )
    with GuardedRobot(harness.robot, limits) as robot:
        start = robot.actual_joints()
        target = start.copy()
        target[2] = 3.5  # J3 beyond +pi
        with pytest.raises(LimitsViolation, match="J3") as info:
            robot.move_joints(target, SPEED, ACCEL)
        assert info.value.joint_index == 2
        with pytest.raises(LimitsViolation, match="speed"):
            robot.move_joints(start + STEP, 2.0, ACCEL)
        np.testing.assert_allclose(robot.actual_joints(), start, atol=harness.tolerance_rad)
        # within limits the guard lets the move through
        robot.move_joints(start + STEP, SPEED, ACCEL)
        np.testing.assert_allclose(robot.actual_joints(), start + STEP, atol=harness.tolerance_rad)


def test_errors_belong_to_the_driver_tree():
    for error in (ProtectiveStop, EmergencyStop, LimitsViolation):
        assert issubclass(error, DriverError)
        assert issubclass(error, IOError)
