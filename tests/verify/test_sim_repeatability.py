"""The simulated arm's opt-in repeatability: random positioning error and backlash."""

import numpy as np
import pytest

from calibrator import robots
from drivers.robot.sim.device import JointRepeatability, SimulatedRobot

Q_A = np.array([0.1, -1.2, 1.0, -1.4, -1.5, 0.2])
Q_B = Q_A + 0.3


def _robot(**kwargs):
    arm = robots.get("ur10e")
    robot = SimulatedRobot(arm.mdh, np.eye(4), np.eye(4), **kwargs)
    robot.connect()
    return robot


def _at(robot, q):
    robot.move_joints(q, 0.5, 1.0)
    return robot.true_tool_pose()[:3, 3]


def test_default_arm_lands_exactly_on_target_whatever_the_approach():
    robot = _robot()
    from_below = _at(robot, Q_A)
    _at(robot, Q_B)
    from_above = _at(robot, Q_A)
    np.testing.assert_array_equal(from_below, from_above)
    np.testing.assert_array_equal(robot.actual_joints(), Q_A)


def test_backlash_shifts_the_pose_by_approach_direction_only():
    robot = _robot(repeatability=JointRepeatability(backlash_rad=20e-6))
    _at(robot, Q_A - 0.3)
    up_1 = _at(robot, Q_A)
    _at(robot, Q_A - 0.3)
    up_2 = _at(robot, Q_A)
    _at(robot, Q_B)
    down = _at(robot, Q_A)
    np.testing.assert_allclose(up_1, up_2, atol=1e-12)  # same side: same pose
    shift = np.linalg.norm(up_1 - down)
    assert 0.005 < shift < 0.2  # 20 urad of lost motion at about 1 m: tens of um
    # Encoders see the target: the read-back hides the backlash.
    np.testing.assert_array_equal(robot.actual_joints(), Q_A)


def test_random_positioning_error_has_the_stated_spread_per_joint():
    std = np.array([1, 2, 3, 4, 5, 6]) * 1e-5
    robot = _robot(
        repeatability=JointRepeatability(positioning_std_rad=std), rng=np.random.default_rng(1)
    )
    errors = []
    for _ in range(2000):
        robot.move_joints(Q_A, 0.5, 1.0)
        errors.append(robot._q_true - Q_A)
    np.testing.assert_allclose(np.std(errors, axis=0, ddof=1), std, rtol=0.06)
    np.testing.assert_allclose(np.mean(errors, axis=0), 0, atol=4 * std.max() / np.sqrt(2000))


def test_repeatability_is_seed_stable():
    def run():
        robot = _robot(repeatability=JointRepeatability.typical(), rng=np.random.default_rng(7))
        return [_at(robot, q) for q in (Q_A, Q_B, Q_A)]

    np.testing.assert_array_equal(run(), run())


def test_random_error_without_a_generator_is_refused():
    with pytest.raises(ValueError, match="rng"):
        _robot(repeatability=JointRepeatability(positioning_std_rad=1e-5))
    with pytest.raises(ValueError, match="backlash_rad"):
        JointRepeatability(backlash_rad=-1.0).arrays()
