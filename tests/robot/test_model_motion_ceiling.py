"""A model's motion ceilings: an option may equal or lower them, never raise them.

``MotionLimits.from_model`` takes the caps from the model's data sheet and
keeps the arm's per-joint speed limits; ``GuardedRobot`` adds the whole-plan
check to whatever the wrapped robot can do.
"""

import dataclasses

import numpy as np
import pytest

from calibrator import robots
from calibrator.acquire import ports
from drivers.robot.errors import LimitsViolation
from drivers.robot.safety import GuardedRobot, MotionLimits, check_plan
from drivers.robot.sim.device import SimulatedRobot


def test_a_cap_equal_to_the_ceiling_is_allowed():
    ur10e = robots.get("ur10e")
    limits = MotionLimits.from_model(
        ur10e,
        max_speed_rad_s=ur10e.move_speed_cap_rad_s,
        max_accel_rad_s2=ur10e.move_accel_cap_rad_s2,
    )
    assert (limits.max_speed_rad_s, limits.max_accel_rad_s2) == (1.0, 2.0)


def test_a_raised_cap_is_refused_with_the_rule_it_breaks():
    with pytest.raises(LimitsViolation) as refused:
        MotionLimits.from_model(robots.get("ur5e"), max_speed_rad_s=1.5)
    assert str(refused.value).endswith("an option can lower a motion limit, never raise it")


@pytest.mark.parametrize(
    ("caps", "name"),
    [
        (dict(max_speed_rad_s="fast"), "max speed"),
        (dict(max_accel_rad_s2=True), "max acceleration"),
    ],
)
def test_a_cap_that_is_no_number_is_refused_by_name(caps, name):
    with pytest.raises(ValueError, match=f"^{name} must be a real number"):
        MotionLimits.from_model(robots.get("ur5e"), **caps)


def test_the_models_joint_speeds_still_bound_a_move():
    # An arm whose wrist turns at 0.5 rad/s: a movej may make the wrist lead, so
    # 0.8 rad/s is refused although it is under the model's 1 rad/s ceiling.
    slow_wrist = dataclasses.replace(
        robots.get("ur5e"), max_joint_speed_rad_s=[3.0, 3.0, 3.0, 3.0, 0.5, 3.0]
    )
    limits = MotionLimits.from_model(slow_wrist)
    np.testing.assert_array_equal(limits.max_joint_speed_rad_s, [3, 3, 3, 3, 0.5, 3])
    check_plan(np.zeros((1, 6)), limits, 0.5, 1.0)
    with pytest.raises(LimitsViolation, match="slowest joint"):
        check_plan(np.zeros((1, 6)), limits, 0.8, 1.0)


def test_a_guarded_robot_keeps_the_robots_capabilities_and_adds_the_plan_check():
    robot = SimulatedRobot.from_model("ur5e", np.random.default_rng(3))
    guarded = GuardedRobot(robot, MotionLimits.from_model(robots.get("ur5e")))
    assert guarded.capabilities == {ports.REPORTS_TRUE_POSE, ports.CHECKS_PLAN}
