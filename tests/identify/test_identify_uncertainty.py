"""Standard errors and predicted errors against the textbook formulas, by hand.

The Jacobian here is taken by central differences of the residuals (not the
module's analytic one), the residual variance as SSR / (M - D), and the
covariance as ``s^2 (J^T J)^-1`` or, with two blocks of different noise, the
sandwich written out with plain matrix inverses.
"""

import numpy as np
import pytest

from calibrator import robots
from calibrator.identify import uncertainty
from calibrator.identify.problem import Problem
from calibrator.model import measurement, parameters, rotations

K = 1.0e4
NAMES = ("a2", "alpha2", "a3", "d3", "theta4", "d4", "base_tx", "base_tz", "base_rz")


def problem(orientation, n=10, seed=4, span=0.3):
    """A space, true deltas and noisy observations of a small ER10L-C10 problem."""
    space = parameters.ParameterSpace(robots.get("er10l-c10").mdh, free=NAMES)
    rng = np.random.default_rng(seed)
    q = rng.uniform(-span, span, (n, 6))
    x = rng.normal(0, 0.01, len(NAMES))
    pose = measurement.predict(space, x, q)
    points = pose[:, :3, 3] + rng.normal(0, 0.05, (n, 3))
    turn = rotations.rotvec_to_matrix(rng.normal(0, 1e-4, (n, 3)))
    rot = turn @ pose[:, :3, :3] if orientation else None
    return space, x, measurement.Observations(q, points, rot)


def fd_jacobian(space, x, obs, k, h=1e-6):
    cols = []
    for i in range(space.size):
        step = np.zeros(space.size)
        step[i] = h
        plus = measurement.residuals(space, x + step, obs, k)
        minus = measurement.residuals(space, x - step, obs, k)
        cols.append((plus - minus) / (2 * h))
    return np.column_stack(cols)


def correlation(cov):
    s = np.sqrt(np.diag(cov))
    return cov / np.outer(s, s)


def test_position_only_errors_are_sqrt_diag_s2_inverse_normal_matrix():
    space, x, obs = problem(orientation=False)
    unc = uncertainty.analyse(Problem.of(space, obs, K), x)  # k is ignored without orientation data
    res = measurement.residuals(space, x, obs)
    jac = fd_jacobian(space, x, obs, 0.0)
    m, d = jac.shape
    s2 = res @ res / (m - d)
    cov = s2 * np.linalg.inv(jac.T @ jac)
    se = np.sqrt(np.diag(cov))
    assert list(unc["standard_errors"]) == list(NAMES)
    np.testing.assert_allclose(list(unc["standard_errors"].values()), se, rtol=1e-4)
    assert unc["residual_sigma"] == {
        "position_mm": pytest.approx(np.sqrt(s2), rel=1e-12),
        "orientation_rad": None,
    }
    assert unc["correlation"]["names"] == list(NAMES)
    np.testing.assert_allclose(unc["correlation"]["matrix"], correlation(cov), atol=2e-5)


def test_two_blocks_use_the_sandwich_with_each_block_s_own_noise():
    space, x, obs = problem(orientation=True)
    unc = uncertainty.analyse(Problem.of(space, obs, K), x)
    res = measurement.residuals(space, x, obs, K)
    jac = fd_jacobian(space, x, obs, K)
    m, d = jac.shape
    n3 = 3 * len(obs)
    # Each block's share of the fit from the hat matrix: E|e_b|^2 = sum_c A_bc var_c.
    i_h = np.eye(m) - jac @ np.linalg.inv(jac.T @ jac) @ jac.T
    blocks = (slice(0, n3), slice(n3, m))
    a = np.array([[np.sum(i_h[b, c] ** 2) for c in blocks] for b in blocks])
    var_p, var_o = np.linalg.solve(a, [res[b] @ res[b] for b in blocks])
    bread = np.linalg.inv(jac.T @ jac)
    s = np.diag(np.r_[np.full(n3, var_p), np.full(m - n3, var_o)])
    cov = bread @ jac.T @ s @ jac @ bread
    np.testing.assert_allclose(
        list(unc["standard_errors"].values()), np.sqrt(np.diag(cov)), rtol=1e-4
    )
    corr = correlation(cov)
    np.testing.assert_allclose(unc["correlation"]["matrix"], corr, atol=2e-5)
    sig = unc["residual_sigma"]
    # rel 1e-8: the hat matrix here comes from the finite-difference Jacobian.
    assert sig["position_mm"] == pytest.approx(np.sqrt(var_p), rel=1e-8)
    assert sig["orientation_rad"] == pytest.approx(np.sqrt(var_o / K), rel=1e-6)
    # Every pair above 0.9 in |r|, strongest first, and only those.
    pairs = [
        (abs(corr[i, j]), NAMES[i], NAMES[j], corr[i, j])
        for i in range(d)
        for j in range(i + 1, d)
        if abs(corr[i, j]) > 0.9
    ]
    pairs.sort(reverse=True)
    assert len(pairs) == 2  # the case this test is about: two strong pairs, sorted
    assert [(p["a"], p["b"]) for p in unc["strong_correlations"]] == [
        (a, b) for _, a, b, _ in pairs
    ]
    np.testing.assert_allclose(
        [p["r"] for p in unc["strong_correlations"]], [r for *_, r in pairs], atol=1e-5
    )


def test_block_sigmas_divide_each_block_by_its_share_of_the_degrees_of_freedom():
    res = np.r_[np.full(6, 2.0), np.full(6, 0.5)]  # 2 poses, 12 rows
    sp, so = uncertainty.block_sigmas(res, 2, 4)
    # 1 - 4/12 of each block's 6 rows is free: 4 dof per block.
    assert sp == pytest.approx(np.sqrt(6 * 4.0 / 4), rel=1e-12)
    assert so == pytest.approx(np.sqrt(6 * 0.25 / 4), rel=1e-12)
    sp, so = uncertainty.block_sigmas(np.full(6, 3.0), 2, 2)
    assert so is None and sp == pytest.approx(np.sqrt(6 * 9.0 / 4), rel=1e-12)
    # As many parameters as rows: the dof floor of 1e-3 keeps it finite.
    sp, _ = uncertainty.block_sigmas(np.full(3, 1.0), 1, 3)
    assert sp == pytest.approx(np.sqrt(1 / 1e-3), rel=1e-12)
    sp, _ = uncertainty.block_sigmas(np.full(3, 1.0), 1, 5)
    assert sp == pytest.approx(np.sqrt(1 / 1e-3), rel=1e-12)


def test_predicted_error_without_parameter_uncertainty_is_the_mean_gaussian_distance():
    space, x, obs = problem(orientation=False, n=4)
    sigma = 0.07
    pred = uncertainty.predict_error(space, x, obs, np.zeros((len(NAMES),) * 2), sigma)
    assert pred["model_rms_mean"] == 0.0 and pred["model_rms_max"] == 0.0
    # E|e| of an isotropic 3-D Gaussian: 2 sigma sqrt(2 / pi) (Maxwell distribution).
    assert pred["error_mean"] == pytest.approx(2 * sigma * np.sqrt(2 / np.pi), rel=1e-12)


def test_predicted_error_propagates_the_covariance_through_each_pose():
    space, x, obs = problem(orientation=True, n=5)
    rng = np.random.default_rng(9)
    a = rng.normal(size=(len(NAMES), len(NAMES))) * 1e-3
    cov = a @ a.T
    sigma = 0.03
    pred = uncertainty.predict_error(space, x, obs, cov, sigma)
    jac = fd_jacobian(space, x, obs, 0.0)  # position rows only
    var = np.array(
        [np.trace(jac[3 * i : 3 * i + 3] @ cov @ jac[3 * i : 3 * i + 3].T) for i in range(len(obs))]
    )
    assert pred["model_rms_mean"] == pytest.approx(np.sqrt(var).mean(), rel=1e-5)
    assert pred["model_rms_max"] == pytest.approx(np.sqrt(var).max(), rel=1e-5)
    total = np.sqrt(var + 3 * sigma**2)
    assert pred["error_mean"] == pytest.approx(np.sqrt(8 / (3 * np.pi)) * total.mean(), rel=1e-5)


def test_analyse_predicts_at_the_held_out_poses_it_is_given():
    space, x, obs = problem(orientation=False, n=12)
    fit, val = obs.subset(np.arange(9)), obs.subset(np.arange(9, 12))
    unc = uncertainty.analyse(Problem.of(space, fit, 0.0), x, val)
    res = measurement.residuals(space, x, fit)
    jac = fd_jacobian(space, x, fit, 0.0)
    s2 = res @ res / (jac.shape[0] - jac.shape[1])
    cov = s2 * np.linalg.inv(jac.T @ jac)
    jv = fd_jacobian(space, x, val, 0.0).reshape(3, 3, -1)
    var = np.einsum("nid,de,nie->n", jv, cov, jv)
    pred = unc["predicted_validation_mm"]
    # The root of s2 from few degrees of freedom is low by c4 on average: divided out.
    c4 = uncertainty.sigma_bias(jac.shape[0] - jac.shape[1])
    assert c4 < 0.99
    assert pred["model_rms_max"] == pytest.approx(np.sqrt(var).max() / c4, rel=1e-4)
    assert pred["error_mean"] == pytest.approx(
        np.sqrt(8 / (3 * np.pi)) * np.sqrt(var + 3 * s2).mean() / c4, rel=1e-4
    )
    assert "predicted_validation_mm" not in uncertainty.analyse(Problem.of(space, fit, 0.0), x)
    assert "predicted_validation_mm" not in uncertainty.analyse(
        Problem.of(space, fit, 0.0), x, obs.subset(np.arange(0))
    )


def test_a_parameter_without_effect_gets_zero_error_and_no_nan():
    # A turn of the tool about its own point moves no position row: a zero column.
    space, x, obs = problem(orientation=False, n=6)
    space = space.with_free(("a2", "d3", "tool_rx"))
    assert not fd_jacobian(space, np.zeros(3), obs, 0.0)[:, 2].any()
    unc = uncertainty.analyse(Problem.of(space, obs, 0.0), np.zeros(3))
    se = unc["standard_errors"]
    assert se["tool_rx"] == 0.0
    assert se["a2"] > 0 and se["d3"] > 0
    corr = np.array(unc["correlation"]["matrix"])
    assert np.all(np.isfinite(corr))
    assert corr[2].tolist() == [0.0, 0.0, 0.0]
    assert corr[0, 0] == pytest.approx(1.0) and corr[1, 1] == pytest.approx(1.0)


def test_summary_lines_name_the_worst_errors_relative_to_range_and_the_pairs():
    unc = {
        # relative to range: a1 0.5, alpha1 0.8, d2 0.12, theta3 0.2
        "standard_errors": {"a1": 0.5, "alpha1": 0.008, "d2": 0.12345, "theta3": 0.002},
        "residual_sigma": {"position_mm": 0.01234, "orientation_rad": np.radians(0.5)},
        "strong_correlations": [
            {"a": "a1", "b": "d2", "r": 0.95},
            {"a": "alpha1", "b": "theta3", "r": -0.93},
            {"a": "a1", "b": "theta3", "r": 0.91},
        ],
        "predicted_validation_mm": {
            "error_mean": 0.1,
            "model_rms_mean": 0.02,
            "model_rms_max": 0.05,
        },
    }
    lines = uncertainty.summary_lines(unc, limit=2)
    assert lines == [
        "standard errors (largest relative to range): alpha1 458 mdeg, a1 500 um",
        "residual sigma: 0.0123 mm per axis, 0.5000 deg",
        "strongly correlated (|r| > 0.9): a1/d2 +0.95, alpha1/theta3 -0.93 and 1 more",
        "predicted held-out position error: mean 0.1000 mm (parameter part 0.0200 mm RMS, "
        "worst 0.0500 mm)",
    ]
    full = uncertainty.summary_lines(unc)
    assert full[0].endswith("alpha1 458 mdeg, a1 500 um, theta3 115 mdeg, d2 123 um")
    assert full[2] == (
        "strongly correlated (|r| > 0.9): a1/d2 +0.95, alpha1/theta3 -0.93, a1/theta3 +0.91"
    )


def test_summary_lines_of_a_bare_position_fit():
    unc = {
        "standard_errors": {},
        "residual_sigma": {"position_mm": 0.5, "orientation_rad": None},
        "strong_correlations": [],
    }
    assert uncertainty.summary_lines(unc) == ["residual sigma: 0.5000 mm per axis"]


def test_summary_lines_show_six_by_default_and_count_only_what_is_left_out():
    names = [f"a{i}" for i in range(1, 7)] + ["d1", "d2"]
    unc = {
        "standard_errors": {n: 0.01 * (i + 1) for i, n in enumerate(names)},
        "residual_sigma": {"position_mm": 0.5, "orientation_rad": None},
        "strong_correlations": [{"a": "a1", "b": n, "r": 0.95} for n in names[1:7]],
    }
    lines = uncertainty.summary_lines(unc)
    assert lines[0] == (
        "standard errors (largest relative to range): d2 80 um, d1 70 um, a6 60 um, "
        "a5 50 um, a4 40 um, a3 30 um"
    )
    # Exactly six pairs: all shown, none "more".
    assert lines[2] == (
        "strongly correlated (|r| > 0.9): a1/a2 +0.95, a1/a3 +0.95, a1/a4 +0.95, "
        "a1/a5 +0.95, a1/a6 +0.95, a1/d1 +0.95"
    )
