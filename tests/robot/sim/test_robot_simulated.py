"""The simulated true arm: hidden errors, where its probe really is, encoder noise, listener."""

import numpy as np
import pytest

from calibrator import robots
from calibrator.model.kinematics import forward, parallel_axes
from calibrator.simulate import random_errors
from drivers.robot.sim.device import SimulatedRobot


def transform(rotvec_z, xyz):
    c, s = np.cos(rotvec_z), np.sin(rotvec_z)
    t = np.eye(4)
    t[:2, :2] = [[c, -s], [s, c]]
    t[:3, 3] = xyz
    return t


BASE2TRACKER = transform(0.3, [2500.0, -400.0, 150.0])
FLANGE2TOOL = transform(0.0, [10.0, 0.0, 120.0])


@pytest.mark.parametrize("name", ["ur5e", "ur10e", "er10l-c10"])
def test_hidden_errors_respect_parallel_axes(name):
    nominal = robots.get(name).mdh
    true = nominal + random_errors(nominal, np.random.default_rng(5))
    delta = true - nominal
    parallel = np.append(parallel_axes(nominal), False)
    assert np.all(delta[:, [0, 1, 2]] != 0)
    # beta only where the next axis is parallel, d only elsewhere
    assert np.all((delta[:, 4] != 0) == parallel)
    assert np.all((delta[:, 3] != 0) == ~parallel)
    assert np.max(np.abs(delta[:, [0, 3]])) < 5.0  # mm: errors, not a different arm


def test_same_seed_same_arm_other_seed_other_arm():
    a = SimulatedRobot.from_model("ur5e", np.random.default_rng(7))
    b = SimulatedRobot.from_model("ur5e", np.random.default_rng(7))
    c = SimulatedRobot.from_model("ur5e", np.random.default_rng(8))
    q = np.array([0.1, -1.2, 1.0, -0.5, 0.7, 0.2])
    poses = []
    for robot in (a, b, c):
        with robot:
            robot.move_joints(q, 1.0, 1.0)
            poses.append(robot.true_tool_pose())
    np.testing.assert_array_equal(poses[0], poses[1])
    assert np.max(np.abs(poses[0][:3, 3] - poses[2][:3, 3])) > 1e-3


def test_true_tool_pose_is_forward_kinematics_of_the_true_arm():
    nominal = robots.get("ur10e").mdh
    true = nominal + random_errors(nominal, np.random.default_rng(3))
    seen = []
    robot = SimulatedRobot(true, BASE2TRACKER, FLANGE2TOOL, listener=seen.append)
    q = np.random.default_rng(4).uniform(-2, 2, size=(3, 6))
    with robot:
        for target in q:
            robot.move_joints(target, 1.0, 1.0)
    expected = forward(true, q, FLANGE2TOOL, BASE2TRACKER)
    np.testing.assert_allclose(np.array(seen), expected, atol=1e-9)
    np.testing.assert_allclose(robot.true_tool_pose(), expected[-1], atol=1e-9)
    # the nominal model puts the probe elsewhere: that difference is what calibration finds
    nominal = forward(robots.get("ur10e").mdh, q, FLANGE2TOOL, BASE2TRACKER)
    assert np.min(np.linalg.norm(nominal[:, :3, 3] - expected[:, :3, 3], axis=1)) > 0.01


def test_encoder_noise_is_seeded_and_stable_per_pose():
    def run(seed):
        robot = SimulatedRobot(
            robots.get("ur5e").mdh,
            np.eye(4),
            np.eye(4),
            joint_noise_rad=1e-4,
            rng=np.random.default_rng(seed),
        )
        with robot:
            reported = robot.move_joints(np.full(6, 0.3), 1.0, 1.0)
            np.testing.assert_array_equal(robot.actual_joints(), reported)  # stable at a pose
            pose = robot.true_tool_pose()
        return reported, pose

    r1, p1 = run(11)
    r2, p2 = run(11)
    np.testing.assert_array_equal(r1, r2)
    error = r1 - 0.3
    assert 0 < np.max(np.abs(error)) < 1e-3
    # the true pose follows the commanded joints, not the encoder readings
    np.testing.assert_array_equal(p1, p2)
    expected = forward(robots.get("ur5e").mdh, np.full((1, 6), 0.3))[0]
    np.testing.assert_allclose(p1, expected, atol=1e-9)


def test_noise_needs_an_explicit_generator():
    with pytest.raises(ValueError, match="rng"):
        SimulatedRobot(robots.get("ur5e").mdh, np.eye(4), np.eye(4), joint_noise_rad=1e-4)


@pytest.mark.parametrize(
    "kwargs, word",
    [
        (dict(true_mdh=np.zeros((5, 5))), "MDH"),
        (dict(base2tracker=np.eye(3)), "base2tracker"),
        (dict(flange2tool=np.eye(3)), "flange2tool"),
        (dict(initial_q=np.zeros(7)), "initial_q"),
    ],
)
def test_constructor_checks_shapes(kwargs, word):
    args = dict(true_mdh=robots.get("ur5e").mdh, base2tracker=np.eye(4), flange2tool=np.eye(4))
    args.update(kwargs)
    true_mdh, base2tracker, flange2tool = (
        args.pop(k) for k in ("true_mdh", "base2tracker", "flange2tool")
    )
    with pytest.raises(ValueError, match=word):
        SimulatedRobot(true_mdh, base2tracker, flange2tool, **args)
