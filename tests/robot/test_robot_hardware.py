"""Hardware tests on a real UR controller: skipped unless ``--robot-host`` is given.

They move only wrist 3, by 0.01 rad from wherever the arm stands, at
0.05 rad/s, after checking both targets against UR e-Series joint limits,
and they return to the start. Run them with the arm clear of obstacles and
someone at the e-stop:

    pytest tests/robot/test_robot_hardware.py --robot-host 192.168.1.10
"""

import numpy as np
import pytest

from calibrator import robots
from drivers.robot.safety import GuardedRobot, MotionLimits
from drivers.robot.ur.device import UrRtdeRobot

STEP_RAD = 0.01  # wrist 3 only: the joint that sweeps the least space
SPEED, ACCEL = 0.05, 0.3
# UR5e and UR10e share their joint limits (+-2 pi, elbow +-pi)
LIMITS = MotionLimits.from_model(robots.get("ur5e"), max_speed_rad_s=0.1, max_accel_rad_s2=0.5)


@pytest.fixture
def real_robot(robot_host):
    robot = GuardedRobot(UrRtdeRobot(robot_host), LIMITS)
    with robot:
        yield robot


def test_reads_joints_and_safety_state(real_robot):
    q = real_robot.actual_joints()
    assert q.shape == (6,)
    assert np.all(np.abs(q) <= 2 * np.pi + 1e-6)
    state = real_robot.safety_state()
    assert isinstance(state.protective_stopped, bool)
    assert isinstance(state.emergency_stopped, bool)


def test_tiny_wrist_move_and_back(real_robot):
    if not real_robot.safety_state().ok:
        pytest.skip("robot is safety-stopped; clear it on the pendant first")
    start = real_robot.actual_joints()
    target = start.copy()
    # step away from the nearer wrist-3 limit
    target[5] += STEP_RAD if start[5] < 0 else -STEP_RAD
    real_robot.check_plan(np.array([target, start]), SPEED, ACCEL)
    reached = real_robot.move_joints(target, SPEED, ACCEL)
    np.testing.assert_allclose(reached, target, atol=real_robot.robot.tolerance_rad)
    np.testing.assert_allclose(reached[:5], start[:5], atol=real_robot.robot.tolerance_rad)
    back = real_robot.move_joints(start, SPEED, ACCEL)
    np.testing.assert_allclose(back, start, atol=real_robot.robot.tolerance_rad)


def test_stop_when_idle_is_harmless(real_robot):
    before = real_robot.actual_joints()
    real_robot.stop()
    np.testing.assert_allclose(real_robot.actual_joints(), before, atol=1e-3)
