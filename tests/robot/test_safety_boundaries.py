"""Limits and caps at their exact boundaries, frozen once checked, and errors that name the field.

Written against the survivors of a mutation run on ``drivers/robot/safety.py``:
the caps are inclusive (a speed equal to the cap or to the slowest joint's
limit is allowed, a hair above is not), a limit below 1 is still a limit, and
every refusal names what was wrong.
"""

import numpy as np
import pytest

from drivers.robot.errors import LimitsViolation
from drivers.robot.safety import GuardedRobot, MotionLimits, check_motion, check_plan
from drivers.robot.sim.device import SimulatedRobot

JOINTS = np.tile([-np.pi, np.pi], (6, 1))
SLOW = np.array([2.0, 2.0, 3.0, 3.0, 0.6, 3.0])  # rad/s; joint 5 is the slowest


def limits(speed=0.5, accel=0.8, joint_speeds=None):
    return MotionLimits(
        JOINTS, max_speed_rad_s=speed, max_accel_rad_s2=accel, max_joint_speed_rad_s=joint_speeds
    )


def test_caps_are_inclusive_and_one_ulp_above_is_refused():
    caps = limits(speed=0.5, accel=0.8)
    check_motion(caps, 0.5, 0.8)  # exactly at both caps: allowed
    with pytest.raises(LimitsViolation, match="speed"):
        check_motion(caps, np.nextafter(0.5, 1.0), 0.8)
    with pytest.raises(LimitsViolation, match="acceleration"):
        check_motion(caps, 0.5, np.nextafter(0.8, 1.0))
    with pytest.raises(LimitsViolation, match="acceleration"):
        check_motion(caps, 0.5, 0.0)


def test_speed_equal_to_the_slowest_joint_is_allowed():
    caps = limits(speed=1.0, joint_speeds=SLOW)
    check_motion(caps, 0.6, 0.5)
    with pytest.raises(LimitsViolation, match=r"slowest joint \(0\.6 rad/s\)"):
        check_motion(caps, np.nextafter(0.6, 1.0), 0.5)


def test_caps_below_one_are_valid_and_zero_is_not():
    assert limits(speed=0.25, accel=0.5).max_speed_rad_s == 0.25
    for field, kwargs in (
        ("max_speed_rad_s", {"speed": 0.0}),
        ("max_accel_rad_s2", {"accel": 0.0}),
    ):
        with pytest.raises(ValueError, match=field):
            limits(**kwargs)


def test_joint_speeds_below_one_are_valid_and_zero_or_nan_is_not():
    caps = limits(joint_speeds=SLOW)
    np.testing.assert_array_equal(caps.max_joint_speed_rad_s, SLOW)
    assert limits(joint_speeds=None).max_joint_speed_rad_s is None
    for bad in ([0.0, 1, 1, 1, 1, 1], [np.nan, 1, 1, 1, 1, 1], [-1.0, 1, 1, 1, 1, 1]):
        with pytest.raises(ValueError, match="max_joint_speed_rad_s must be finite and > 0"):
            limits(joint_speeds=bad)
    with pytest.raises(ValueError, match=r"max_joint_speed_rad_s must have shape \(6,\)"):
        limits(joint_speeds=[1.0] * 5)


def test_a_joint_range_of_zero_width_is_refused():
    equal = JOINTS.copy()
    equal[2] = [0.5, 0.5]
    with pytest.raises(ValueError, match="min < max"):
        MotionLimits(equal, max_speed_rad_s=1.0, max_accel_rad_s2=1.0)


def test_checked_limits_are_frozen():
    caps = limits(joint_speeds=SLOW)
    with pytest.raises(ValueError, match="read-only"):
        caps.joint_limits_rad[0, 1] = 10.0
    with pytest.raises(ValueError, match="read-only"):
        caps.max_joint_speed_rad_s[4] = 10.0


@pytest.mark.parametrize(
    ("build", "field"),
    [
        (lambda: MotionLimits([["a", "b"]] * 6, 1.0, 1.0), "joint_limits_rad"),
        (lambda: MotionLimits(JOINTS, True, 1.0), "max_speed_rad_s"),
        (lambda: MotionLimits(JOINTS, 1.0, 1j), "max_accel_rad_s2"),
        (lambda: limits(joint_speeds=["x"] * 6), "max_joint_speed_rad_s"),
        (lambda: check_motion(limits(), "0.1", 0.5), "speed_rad_s"),
        (lambda: check_motion(limits(), 0.1, [0.5]), "accel_rad_s2"),
        (lambda: check_plan([[0.1 + 0j] * 6], limits(), 0.1, 0.5), "plan"),
    ],
)
def test_a_value_that_is_not_a_real_number_is_refused_by_name(build, field):
    with pytest.raises(ValueError, match=rf"^{field} must hold|^{field} must be a real"):
        build()


def test_guarded_move_names_a_bad_target():
    rng = np.random.default_rng(0)
    robot = GuardedRobot(SimulatedRobot.from_model("ur5e", rng), limits())
    with pytest.raises(ValueError, match="^joint target must hold real numbers"):
        robot.move_joints([True] * 6, 0.1, 0.5)
    with pytest.raises(ValueError, match=r"^joint target must have shape \(6,\), got \(5,\)"):
        robot.move_joints([0.0] * 5, 0.1, 0.5)
