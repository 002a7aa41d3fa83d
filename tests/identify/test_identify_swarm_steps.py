"""The swarm's fast paths against plain versions written out step by step.

``pso.ipso`` draws its random numbers several generations at a time and forms
both pulls in one array; the plain loop below draws once per generation and
forms each term as the IPSO paper writes it. The swarm objective keeps work arrays
per swarm size; its results must not depend on earlier calls.
"""

import numpy as np
import pytest

from calibrator import robots
from calibrator.halton import halton
from calibrator.identify import pso
from calibrator.identify.problem import Problem
from calibrator.model import frames, kinematics, measurement, parameters, rotations


def plain_ipso(objective, lower, upper, particles, generations, seed, c1=2.05, c2=2.05):
    """The IPSO paper's swarm, one draw of r1, r2 per generation, each term on its own."""
    rng = np.random.default_rng(seed) if isinstance(seed, int) else seed
    dim = lower.size
    centre, half = (upper + lower) / 2, (upper - lower) / 2
    start = halton(particles, 2 * dim, rng) * 2 - 1
    x = centre + 0.25 * half * start[:, :dim]
    v = 0.25 * half * start[:, dim:]
    k = pso.constriction(c1, c2)
    f = objective(x)
    best_x, best_f = x.copy(), f.copy()
    history = [best_f.min()]
    for _ in range(generations):
        r = rng.random((2, particles, dim))
        g = np.argmin(best_f)
        own = (k * c1 * r[0]) * (best_x - x)
        social = (k * c2 * r[1]) * (best_x[g] - x)
        v = k * v + own + social
        v = np.maximum(np.minimum(v, half), -half)
        x = np.maximum(np.minimum(x + v, upper), lower)
        f = objective(x)
        better = f < best_f
        best_x[better], best_f[better] = x[better], f[better]
        history.append(best_f.min())
    return best_x[np.argmin(best_f)], np.array(history)


def wavy(x):
    return np.sum((x - 0.1) ** 2, axis=1) + 0.1 * np.sum(np.sin(7 * x), axis=1)


@pytest.mark.parametrize("generations", [0, 1, 15, 16, 17, 50])
def test_ipso_is_the_plain_loop_to_the_bit(generations):
    lower, upper = -np.ones(5), np.array([1.0, 2.0, 0.5, 1.0, 3.0])
    x, history = plain_ipso(wavy, lower, upper, 7, generations, seed=4)
    found = pso.ipso(wavy, lower, upper, particles=7, generations=generations, seed=4)
    np.testing.assert_array_equal(found.history, history)
    np.testing.assert_array_equal(found.x, x)


def test_ipso_with_unequal_coefficients_is_the_plain_loop():
    lower, upper = -np.ones(3), np.ones(3)
    x, history = plain_ipso(wavy, lower, upper, 6, 40, seed=2, c1=2.3, c2=1.9)
    found = pso.ipso(wavy, lower, upper, particles=6, generations=40, seed=2, c1=2.3, c2=1.9)
    np.testing.assert_array_equal(found.history, history)
    np.testing.assert_array_equal(found.x, x)


def test_a_generator_passed_in_is_left_where_the_plain_loop_leaves_it():
    lower, upper = -np.ones(4), np.ones(4)
    ours, plain = np.random.default_rng(11), np.random.default_rng(11)
    pso.ipso(wavy, lower, upper, particles=5, generations=21, seed=ours)
    plain_ipso(wavy, lower, upper, 5, 21, seed=plain)
    assert ours.random() == plain.random()


ROBOT = robots.get("er10l-c10")
TOOL0 = frames.transform(rotations.rotations_xyz([0.0, 0.3, 0.0]), [10.0, 0.0, 80.0])
BASE0 = frames.transform(rotations.rotations_xyz([0.1, -0.2, 0.3]), [500.0, -200.0, 100.0])


def by_hand(space, swarm, obs, k):
    """Objective (7) per particle with ``forward``: squared errors plus k (3 - trace)."""
    out = []
    for x in swarm:
        mdh, base, tool = space.unpack(x)
        pose = kinematics.forward(mdh, obs.q, tool, base)
        trace = np.einsum("nji,nji->n", obs.rotations, pose[:, :3, :3])
        out.append(np.sum((pose[:, :3, 3] - obs.points) ** 2) + k * np.sum(3.0 - trace))
    return np.array(out)


FRAMES = parameters.BASE_NAMES + parameters.TOOL_NAMES + parameters.TOOL_ROTATION_NAMES


@pytest.mark.parametrize("frames_free", [(), FRAMES], ids=["frames fixed", "frames free"])
@pytest.mark.parametrize("base0", [np.eye(4), BASE0], ids=["base frame", "fixed base offset"])
def test_swarm_objective_keeps_no_state_between_calls_or_swarm_sizes(base0, frames_free):
    # Every MDH parameter free (beta too), with or without both frames; the
    # objective keeps its work arrays per swarm size.
    rng = np.random.default_rng(3)
    q = rng.uniform(-2.5, 2.5, (9, 6))
    pose = kinematics.forward(ROBOT.mdh + rng.normal(0, 1e-3, (6, 5)), q, TOOL0, base0)
    obs = measurement.Observations(
        q,
        pose[:, :3, 3] + rng.normal(0, 0.1, (9, 3)),
        rotations.rotvec_to_matrix(rng.normal(0, 1e-3, (9, 3))) @ pose[:, :3, :3],
    )
    space = parameters.ParameterSpace(ROBOT.mdh, base0, TOOL0, parameters.MDH_NAMES + frames_free)
    objective = Problem.of(space, obs, 1.0e4).swarm_objective()
    lower, upper = space.bounds()
    swarms = [rng.uniform(lower, upper, (n, space.size)) for n in (4, 7, 4, 1)]
    values = [objective(s) for s in swarms]
    for s, f in zip(swarms, values, strict=True):
        # Earlier results are not overwritten by later calls, and match the formula.
        np.testing.assert_allclose(f, by_hand(space, s, obs, 1.0e4), rtol=1e-9)
    np.testing.assert_array_equal(objective(swarms[0]), values[0])
