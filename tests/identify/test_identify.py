"""Identification end to end on simulated sessions (the issue's acceptance cases)."""

import numpy as np
import pytest
from session_kit import simulated

from calibrator.identify import accuracy, pipeline, pso, refine
from calibrator.identify.problem import Problem


def seed_case(tmp_path, noise_mm=0.0, seed=3):
    # The IPSO paper: ER10L-C10, Table 2 errors, 32 poses, base frame, orientation.
    return simulated(
        tmp_path,
        model="er10l-c10",
        poses=32,
        seed=seed,
        frame="base",
        orientation=True,
        noise_mm=noise_mm,
        errors="seed",
    )


def test_seed_case_hybrid_recovers_all_24_parameters(tmp_path):
    loaded, truth = seed_case(tmp_path)
    result = pipeline.identify(loaded, pipeline.Options(method="hybrid", seed=0))
    assert result.space.size == 24
    np.testing.assert_allclose(result.mdh, truth.mdh, atol=1e-6, rtol=0)
    assert result.stats["validation"]["after"]["position_mm"]["max"] < 1e-6
    assert result.stats["validation"]["before"]["position_mm"]["mean"] > 1.0


@pytest.mark.parametrize("seed", [3, 4])
def test_seed_case_with_noise_holds_out_to_the_noise_floor(tmp_path, seed):
    loaded, _ = seed_case(tmp_path, noise_mm=0.02, seed=seed)
    result = pipeline.identify(loaded, pipeline.Options(seed=seed))
    assert len(result.validation_index) == 6
    assert result.stats["validation"]["after"]["position_mm"]["mean"] <= 0.03


def held_out_mean(space, x, obs):
    return accuracy.error_stats(space, x, obs)["position_mm"]["mean"]


@pytest.mark.parametrize("orientation", [False, True])
def test_unknown_base_and_tool_on_ur10e_matches_a_fit_started_from_the_truth(tmp_path, orientation):
    loaded, truth = simulated(
        tmp_path,
        model="ur10e",
        poses=40,
        seed=21,
        frame="tracker",
        orientation=orientation,
        noise_mm=0.03,
        orientation_noise_rad=np.radians(0.005),
        errors="random",
        tool_offset_mm=8.0,
    )
    result = pipeline.identify(loaded, pipeline.Options(seed=1))
    # The base frame is metres away and turned: the first guess is closed form.
    assert np.linalg.norm(truth.base2tracker[:3, 3]) > 2000
    obs = loaded.observations
    fit, val = obs.subset(result.fit_index), obs.subset(result.validation_index)
    from_truth = refine.refine(
        Problem.of(result.space, fit, result.k),
        result.space.pack(truth.mdh, truth.base2tracker, truth.flange2tool),
    )
    ours = held_out_mean(result.space, result.x, val)
    reference = held_out_mean(result.space, from_truth.x, val)
    assert ours <= 1.5 * reference
    assert ours < 0.1
    assert result.stats["validation"]["before"]["position_mm"]["mean"] > 1.0


def test_methods_agree_on_the_least_squares_optimum(tmp_path):
    loaded, _ = seed_case(tmp_path, noise_mm=0.02)
    hybrid = pipeline.identify(loaded, pipeline.Options(method="hybrid"))
    lm = pipeline.identify(loaded, pipeline.Options(method="lm"))
    pso_only = pipeline.identify(loaded, pipeline.Options(method="pso"))
    costs = [
        r.details.get("least_squares", r.details.get("pso"))["objective"]
        for r in (hybrid, lm, pso_only)
    ]
    assert costs[0] == pytest.approx(costs[1], rel=1e-6)
    assert costs[2] >= costs[0]
    assert "least_squares" not in pso_only.details


def test_swarm_objective_equals_the_sum_of_squared_residuals(tmp_path):
    from calibrator.model import measurement

    loaded, _ = simulated(
        tmp_path,
        model="ur10e",
        poses=12,
        seed=2,
        frame="tracker",
        noise_mm=0.05,
        orientation_noise_rad=1e-4,
        errors="random",
        tool_offset_mm=3.0,
    )
    result = pipeline.identify(loaded, pipeline.Options(method="lm", validation_fraction=0))
    obs = loaded.observations
    swarm = np.random.default_rng(0).normal(0, 0.002, (6, result.space.size))
    for k in (0.0, 1e4):
        f = Problem.of(result.space, obs, k).swarm_objective()(swarm)
        direct = [np.sum(measurement.residuals(result.space, x, obs, k) ** 2) for x in swarm]
        # The swarm's chordal orientation term equals theta^2 to fourth order.
        np.testing.assert_allclose(f, direct, rtol=1e-5)


def test_ipso_finds_a_shifted_bowl_and_is_reproducible():
    target = np.linspace(-0.3, 0.4, 8)

    def bowl(x):
        return np.sum((x - target) ** 2 * np.arange(1, 9), axis=1)

    lower, upper = -np.ones(8), np.ones(8)
    a = pso.ipso(bowl, lower, upper, particles=20, generations=400, seed=5)
    b = pso.ipso(bowl, lower, upper, particles=20, generations=400, seed=5)
    np.testing.assert_allclose(a.x, target, atol=1e-4)
    np.testing.assert_array_equal(a.x, b.x)
    assert np.all(np.diff(a.history) <= 0)
    assert pso.constriction(2.05, 2.05) == pytest.approx(0.7298, abs=1e-4)


def test_validation_split_is_seeded_and_disjoint():
    fit, val = pipeline.split(32, 0.2, seed=9)
    fit2, val2 = pipeline.split(32, 0.2, seed=9)
    assert len(val) == 6 and len(fit) == 26
    assert not set(fit) & set(val)
    np.testing.assert_array_equal(val, val2)
    assert len(pipeline.split(32, 0.0, seed=9)[1]) == 0


def test_too_few_poses_for_the_free_parameters(tmp_path):
    loaded, _ = simulated(
        tmp_path, model="er10l-c10", poses=5, seed=3, orientation=False, errors="seed"
    )
    with pytest.raises(pipeline.IdentifiabilityError, match="cannot identify"):
        pipeline.identify(loaded, pipeline.Options(validation_fraction=0))
