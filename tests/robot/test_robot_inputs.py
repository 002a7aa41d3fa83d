"""Robot inputs are real numbers or refused, before any motion (issue 8, item 10).

Complex joint targets used to be cast to real with only a warning, a bool
speed counted as 1.0, and a NaN in a speed limit turned that check off.
"""

import warnings

import numpy as np
import pytest

from calibrator import robots
from drivers.robot.errors import LimitsViolation
from drivers.robot.interface import check_move_args
from drivers.robot.safety import GuardedRobot, MotionLimits, check_motion, check_plan
from drivers.robot.sim.device import SimulatedRobot

UR10E = robots.get("ur10e")
LIMITS = MotionLimits.from_model(UR10E, max_speed_rad_s=1.0, max_accel_rad_s2=2.0)
Q0 = np.zeros(6)
REFUSED = (LimitsViolation, ValueError)


def _robot():
    robot = SimulatedRobot(UR10E.mdh, np.eye(4), np.eye(4), initial_q=Q0)
    robot.connect()
    return robot


BAD_TARGETS = [
    Q0 + 0.1j,
    np.full(6, 0.1, dtype=complex),
    [0.1, 0.2, 0.3, 0.4, 0.5, 0.6 + 0j],
    [True, False, True, False, True, False],
    np.ones(6, dtype=bool),
    ["0.1"] * 6,
    [None] * 6,
    np.array([0.1] * 6, dtype=object),
]
BAD_SCALARS = [True, False, np.bool_(True), 1 + 0j, complex(0.5, 0), "0.5", None, [0.5], np.nan]


@pytest.mark.parametrize("q", BAD_TARGETS, ids=range(len(BAD_TARGETS)))
def test_non_real_joint_targets_are_refused_without_a_move(q):
    robot = _robot()
    guarded = GuardedRobot(robot, LIMITS)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a ComplexWarning is not a refusal
        with pytest.raises(REFUSED):
            guarded.move_joints(q, 0.5, 1.0)
        with pytest.raises(REFUSED):
            robot.move_joints(q, 0.5, 1.0)
        with pytest.raises(REFUSED):
            check_plan([q], LIMITS, 0.5, 1.0)
    np.testing.assert_array_equal(robot.actual_joints(), Q0)


@pytest.mark.parametrize("value", BAD_SCALARS, ids=repr)
def test_non_real_speed_or_acceleration_is_refused_without_a_move(value):
    robot = _robot()
    guarded = GuardedRobot(robot, LIMITS)
    target = np.full(6, 0.1)
    for speed, accel in ((value, 1.0), (0.5, value)):
        with pytest.raises(REFUSED):
            guarded.move_joints(target, speed, accel)
        with pytest.raises(REFUSED):
            robot.move_joints(target, speed, accel)
        with pytest.raises(REFUSED):
            check_move_args(target, speed, accel)
        with pytest.raises(REFUSED):
            check_motion(LIMITS, speed, accel)
    np.testing.assert_array_equal(robot.actual_joints(), Q0)


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(max_joint_speed_rad_s=[np.nan, 1, 1, 1, 1, 1]),
        dict(max_joint_speed_rad_s=[np.inf] * 6),
        dict(max_joint_speed_rad_s=[0.0] * 6),
        dict(max_joint_speed_rad_s=[-1.0] * 6),
        dict(max_joint_speed_rad_s=[1j] * 6),
        dict(max_speed_rad_s=np.nan),
        dict(max_speed_rad_s=True),
        dict(max_accel_rad_s2=np.nan),
        dict(max_accel_rad_s2=1j),
        dict(joint_limits_rad=np.tile([-np.pi, np.nan], (6, 1))),
        dict(joint_limits_rad=np.tile([-np.pi, np.pi], (6, 1)) + 0j),
        dict(joint_limits_rad=np.tile([True, False], (6, 1))),
    ],
    ids=range(12),
)
def test_limits_that_would_turn_a_check_off_are_refused(kwargs):
    args = dict(
        joint_limits_rad=UR10E.joint_limits_rad,
        max_speed_rad_s=1.0,
        max_accel_rad_s2=2.0,
        max_joint_speed_rad_s=UR10E.max_joint_speed_rad_s,
    )
    args.update(kwargs)
    with pytest.raises(ValueError):
        MotionLimits(**args)


def test_real_inputs_of_any_numeric_type_still_move():
    robot = _robot()
    guarded = GuardedRobot(robot, LIMITS)
    target = np.full(6, 0.1, dtype=np.float32)
    got = guarded.move_joints(target, np.float64(0.5), 1)
    np.testing.assert_allclose(got, target, atol=1e-6)
    guarded.move_joints([0, 0, 0, 0, 0, 0], 0.5, np.int64(1))
    np.testing.assert_allclose(robot.actual_joints(), Q0, atol=1e-9)
