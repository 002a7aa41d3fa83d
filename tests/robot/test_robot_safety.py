"""Safety before motion: whole plans checked against joint limits and speed/accel caps."""

import numpy as np
import pytest

from calibrator import robots
from drivers.robot.errors import LimitsViolation
from drivers.robot.safety import GuardedRobot, MotionLimits, check_plan
from drivers.robot.sim.device import SimulatedRobot

LIMITS = MotionLimits(np.tile([-np.pi, np.pi], (6, 1)), max_speed_rad_s=1.0, max_accel_rad_s2=2.0)


def plan(n, rng):
    return rng.uniform(-3.0, 3.0, size=(n, 6))


def test_plan_within_limits_passes_unchanged():
    q = plan(50, np.random.default_rng(0))
    np.testing.assert_array_equal(check_plan(q, LIMITS, 0.5, 1.0), q)


def test_out_of_limit_pose_named_by_row_and_joint():
    q = plan(20, np.random.default_rng(1))
    q[7, 4] = 3.3  # J5 above +pi
    q[12, 0] = -3.3
    with pytest.raises(LimitsViolation, match=r"pose 7 .*J5") as info:
        check_plan(q, LIMITS, 0.5, 1.0)
    assert (info.value.pose_index, info.value.joint_index) == (7, 4)
    assert "2 out of limits" in str(info.value)


def test_limits_are_inclusive_and_nan_is_refused():
    q = np.zeros((2, 6))
    q[0, 1] = np.pi  # exactly on the limit is allowed
    check_plan(q, LIMITS, 0.5, 1.0)
    q[1, 2] = np.nan
    with pytest.raises(LimitsViolation, match="J3"):
        check_plan(q, LIMITS, 0.5, 1.0)


@pytest.mark.parametrize(
    "speed, accel, word",
    [
        (1.5, 1.0, "speed"),
        (0.0, 1.0, "speed"),
        (np.inf, 1.0, "speed"),
        (0.5, 2.5, "acceleration"),
        (0.5, -1.0, "acceleration"),
    ],
)
def test_speed_and_acceleration_caps(speed, accel, word):
    with pytest.raises(LimitsViolation, match=word) as info:
        check_plan(np.zeros((3, 6)), LIMITS, speed, accel)
    assert info.value.pose_index is None


def test_model_limits_and_joint_speed():
    ur10e = robots.get("ur10e")
    limits = MotionLimits(
        ur10e.joint_limits_rad, 3.0, 3.0, max_joint_speed_rad_s=ur10e.max_joint_speed_rad_s
    )
    check_plan(np.zeros((1, 6)), limits, 2.0, 1.0)
    # UR10e base and shoulder turn at most 120 deg/s: a faster movej could exceed them
    with pytest.raises(LimitsViolation, match="slowest joint"):
        check_plan(np.zeros((1, 6)), limits, 2.5, 1.0)
    q = np.zeros((1, 6))
    q[0, 2] = 3.2  # the UR elbow is limited to +-pi
    with pytest.raises(LimitsViolation, match="J3"):
        check_plan(q, limits, 1.0, 1.0)


def test_a_models_limits_are_its_fixed_ceilings_by_default():
    ur10e = robots.get("ur10e")
    limits = MotionLimits.from_model(ur10e)
    np.testing.assert_array_equal(limits.joint_limits_rad, ur10e.joint_limits_rad)
    assert (limits.max_speed_rad_s, limits.max_accel_rad_s2) == (1.0, 2.0)
    check_plan(np.zeros((1, 6)), limits, 1.0, 2.0)
    with pytest.raises(LimitsViolation, match="acceleration 2.5"):
        check_plan(np.zeros((1, 6)), limits, 1.0, 2.5)


@pytest.mark.parametrize(
    ("caps", "word"),
    [
        (dict(max_speed_rad_s=1.0000001), "speed cap 1.0000001 rad/s above the ur10e ceiling"),
        (dict(max_accel_rad_s2=39.0), "acceleration cap 39.0 rad/s\\^2 above the ur10e ceiling"),
        (dict(max_accel_rad_s2=float("nan")), "acceleration cap nan"),
    ],
)
def test_a_user_cap_cannot_raise_a_models_ceiling(caps, word):
    with pytest.raises(LimitsViolation, match=word):
        MotionLimits.from_model(robots.get("ur10e"), **caps)


def test_a_user_cap_lowers_a_models_ceiling():
    limits = MotionLimits.from_model(robots.get("ur5e"), max_speed_rad_s=0.2, max_accel_rad_s2=0.5)
    assert (limits.max_speed_rad_s, limits.max_accel_rad_s2) == (0.2, 0.5)
    with pytest.raises(LimitsViolation, match="speed 0.3"):
        check_plan(np.zeros((1, 6)), limits, 0.3, 0.5)


@pytest.mark.parametrize("shape", [(6,), (3, 5), (2, 6, 1)])
def test_plan_shape_checked(shape):
    with pytest.raises(ValueError, match=r"\(N, 6\)"):
        check_plan(np.zeros(shape), LIMITS, 0.5, 1.0)


def test_bad_limits_rejected():
    with pytest.raises(ValueError, match="min < max"):
        MotionLimits(np.tile([1.0, -1.0], (6, 1)), 1.0, 1.0)
    with pytest.raises(ValueError, match=r"\(6, 2\)"):
        MotionLimits(np.zeros((5, 2)), 1.0, 1.0)
    with pytest.raises(ValueError, match="max_speed"):
        MotionLimits(np.tile([-1.0, 1.0], (6, 1)), 0.0, 1.0)


def test_guarded_plan_refused_whole_before_any_move():
    moves = []
    robot = SimulatedRobot(
        robots.get("ur5e").mdh, np.eye(4), np.eye(4), listener=lambda pose: moves.append(pose)
    )
    guarded = GuardedRobot(robot, LIMITS)
    q = plan(10, np.random.default_rng(2))
    q[9, 5] = 4.0  # only the last pose is bad
    with guarded:
        with pytest.raises(LimitsViolation, match="pose 9"):
            guarded.check_plan(q, 0.5, 1.0)
        assert moves == []
        good = guarded.check_plan(q[:9], 0.5, 1.0)
        for target in good:
            guarded.move_joints(target, 0.5, 1.0)
    assert len(moves) == 9
