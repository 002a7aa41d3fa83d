"""The swarm objective against the IPSO paper's formula, written out per particle with ``forward``.

Every branch of the batched evaluation (base frame free, fixed or the
identity; tool point and tool turn free or not; least squares or the worst
pose) is compared with a plain loop: forward kinematics of each particle's
arm, squared position errors, and ``k (3 - trace(R_meas^T R_model))``.
"""

import numpy as np
import pytest

from calibrator import robots
from calibrator.identify.problem import Problem
from calibrator.model import frames, kinematics, measurement, parameters, rotations

K = 1.0e4
ROBOT = robots.get("er10l-c10")
BASE0 = frames.transform(rotations.rotations_xyz([0.1, -0.2, 0.3]), [500.0, -200.0, 100.0])
TOOL0 = frames.transform(rotations.rotations_xyz([0.0, 0.3, 0.0]), [10.0, 0.0, 80.0])


def observations(seed, n=6):
    rng = np.random.default_rng(seed)
    q = rng.uniform(-2, 2, (n, 6))
    pose = kinematics.forward(ROBOT.mdh, q, TOOL0, BASE0)
    points = pose[:, :3, 3] + rng.normal(0, 0.5, (n, 3))
    rot = rotations.rotvec_to_matrix(rng.normal(0, 5e-3, (n, 3))) @ pose[:, :3, :3]
    return measurement.Observations(q, points, rot)


def by_hand(space, swarm, obs, k, worst):
    out = []
    for x in swarm:
        mdh, base, tool = space.unpack(x)
        pose = kinematics.forward(mdh, obs.q, tool, base)
        per_pose = np.sum((pose[:, :3, 3] - obs.points) ** 2, axis=1)
        if k:
            trace = np.einsum("nji,nji->n", obs.rotations, pose[:, :3, :3])
            per_pose = per_pose + k * (3.0 - trace)
        out.append(per_pose.max() if worst else per_pose.sum())
    return np.array(out)


MDH_FREE = ("a2", "alpha2", "theta3", "d4", "beta2")
CASES = {
    "mdh only": MDH_FREE,
    "base free": MDH_FREE + ("base_tx", "base_rz", "base_ry"),
    "tool point free": MDH_FREE + ("tool_x", "tool_z"),
    "tool turn free": MDH_FREE + ("tool_y", "tool_rx", "tool_rz"),
    "everything": MDH_FREE + ("base_ty", "base_rx", "tool_x", "tool_ry"),
    # The first parameter of each block alone: the block must still count as free.
    "base_tx alone": MDH_FREE + ("base_tx",),
    "tool_x alone": MDH_FREE + ("tool_x",),
    "tool_rx alone": MDH_FREE + ("tool_rx",),
}


@pytest.mark.parametrize("loss", ["lsq", "minimax"])
@pytest.mark.parametrize("k", [0.0, K])
@pytest.mark.parametrize("base0", ["identity", "offset"])
@pytest.mark.parametrize("case", list(CASES))
def test_swarm_objective_is_the_seed_formula_per_particle(case, base0, k, loss):
    base = np.eye(4) if base0 == "identity" else BASE0
    space = parameters.ParameterSpace(ROBOT.mdh, base, TOOL0, CASES[case])
    obs = observations(seed=len(case))
    if base0 == "identity":
        obs = measurement.Observations(
            obs.q,
            (obs.points - BASE0[:3, 3]) @ BASE0[:3, :3],
            BASE0[:3, :3].T @ obs.rotations,
        )
    rng = np.random.default_rng(7)
    lower, upper = space.bounds()
    swarm = rng.uniform(lower, upper, (4, space.size)) * 0.5
    f = Problem.of(space, obs, k).swarm_objective(loss)(swarm)
    expected = by_hand(space, swarm, obs, k, loss == "minimax")
    np.testing.assert_allclose(f, expected, rtol=1e-9)


def test_orientation_is_ignored_without_orientation_data():
    space = parameters.ParameterSpace(ROBOT.mdh, BASE0, TOOL0, CASES["everything"])
    obs = observations(seed=3)
    bare = measurement.Observations(obs.q, obs.points)
    swarm = np.random.default_rng(1).uniform(-0.01, 0.01, (3, space.size))
    for loss in ("lsq", "minimax"):
        f = Problem.of(space, bare, K).swarm_objective(loss)(swarm)
        np.testing.assert_allclose(f, by_hand(space, swarm, bare, 0.0, loss == "minimax"))


def test_defaults_are_least_squares_on_positions():
    space = parameters.ParameterSpace(ROBOT.mdh, BASE0, TOOL0, CASES["everything"])
    obs = observations(seed=4)
    swarm = np.random.default_rng(2).uniform(-0.01, 0.01, (3, space.size))
    f = Problem.of(space, obs, 0.0).swarm_objective()(swarm)
    np.testing.assert_allclose(f, by_hand(space, swarm, obs, 0.0, False), rtol=1e-9)


def test_an_unknown_loss_is_refused():
    space = parameters.ParameterSpace(ROBOT.mdh, free=MDH_FREE)
    with pytest.raises(ValueError, match="swarm loss must be 'lsq' or 'minimax', got 'huber'"):
        Problem.of(space, observations(seed=1), K).swarm_objective("huber")
