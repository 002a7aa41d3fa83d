"""Joint limits are exact: 1e-6 rad past either end of any joint is refused, on it is allowed."""

import numpy as np
import pytest

from calibrator import robots
from drivers.robot.errors import LimitsViolation
from drivers.robot.safety import GuardedRobot, MotionLimits, check_plan
from drivers.robot.sim.device import SimulatedRobot

EPS = 1e-6
# Asymmetric and different per joint, so a limit read from the wrong joint or end shows.
ASYMMETRIC = np.array(
    [[-3.0, 2.5], [-2.0, 0.5], [-0.7, 2.9], [-1.1, 1.3], [-2.2, 0.2], [-0.3, 3.1]]
)
CASES = [
    MotionLimits(ASYMMETRIC, max_speed_rad_s=1.0, max_accel_rad_s2=2.0),
    MotionLimits.from_model(robots.get("ur10e"), max_speed_rad_s=1.0, max_accel_rad_s2=2.0),
]


def mid(limits):
    return limits.joint_limits_rad.mean(axis=1)


@pytest.mark.parametrize("limits", CASES, ids=["asymmetric", "ur10e"])
@pytest.mark.parametrize("joint", range(6))
@pytest.mark.parametrize("end", [0, 1], ids=["min", "max"])
def test_one_microradian_past_a_limit_is_refused_on_every_joint(limits, joint, end):
    limit = limits.joint_limits_rad[joint, end]
    outward = -1.0 if end == 0 else 1.0
    q = np.tile(mid(limits), (3, 1))
    q[1, joint] = limit  # on the limit: allowed
    q[2, joint] = limit - outward * EPS  # just inside: allowed
    np.testing.assert_array_equal(check_plan(q, limits, 0.5, 1.0), q)
    q[2, joint] = limit + outward * EPS  # just outside: the whole plan is refused
    with pytest.raises(LimitsViolation) as info:
        check_plan(q, limits, 0.5, 1.0)
    assert (info.value.pose_index, info.value.joint_index) == (2, joint)
    assert f"J{joint + 1}" in str(info.value)


@pytest.mark.parametrize("joint", range(6))
def test_a_single_guarded_move_one_microradian_out_never_reaches_the_robot(joint):
    moves = []
    robot = SimulatedRobot(
        robots.get("ur10e").mdh, np.eye(4), np.eye(4), listener=lambda pose: moves.append(pose)
    )
    limits = CASES[0]
    guarded = GuardedRobot(robot, limits)
    target = mid(limits)
    target[joint] = limits.joint_limits_rad[joint, 1] + EPS
    with guarded:
        with pytest.raises(LimitsViolation):
            guarded.move_joints(target, 0.5, 1.0)
        assert moves == []
        target[joint] -= 2 * EPS
        guarded.move_joints(target, 0.5, 1.0)
    assert len(moves) == 1
