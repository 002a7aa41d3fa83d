"""Robust fits against their textbook definitions, on a small noisy problem with outliers.

Huber: at the answer the gradient of ``sum rho_c(r_i / s_i)`` vanishes,
with ``rho_c`` quadratic within ``c = 1.345`` and linear beyond, i.e. the
textbook weights ``min(1, c / |z|)``. Trimmed: the answer is the plain
least-squares fit (scipy, finite differences) of the poses it keeps, and
it sets aside exactly the poses whose whitened error exceeds the Bonferroni
chi-square point of the outlier test.
"""

import warnings

import numpy as np
import pytest
from scipy import stats
from scipy.optimize import least_squares

from calibrator import robots
from calibrator.identify import refine, robust
from calibrator.identify.problem import Problem
from calibrator.model import measurement, parameters, rotations

K = 1.0e4
NAMES = ("a2", "alpha2", "d4", "theta5", "base_tx", "base_ty", "base_rz")


def problem(orientation, n=24, seed=3):
    """Small ER10L-C10 problem: noise 0.05 mm / 1 mrad, pose 5 off by 3 mm,
    and with orientation data pose 11 turned by 20 mrad."""
    space = parameters.ParameterSpace(robots.get("er10l-c10").mdh, free=NAMES)
    rng = np.random.default_rng(seed)
    q = rng.uniform(-1.5, 1.5, (n, 6))
    x = rng.normal(0, 0.02, len(NAMES))
    pose = measurement.predict(space, x, q)
    points = pose[:, :3, 3] + rng.normal(0, 0.05, (n, 3))
    points[5] += [3.0, -1.0, 2.0]
    rot = None
    if orientation:
        turn = rng.normal(0, 1e-3, (n, 3))  # weighted: 0.1, twice the position noise
        turn[11] += [2e-2, 0.0, 0.0]
        rot = rotations.rotvec_to_matrix(turn) @ pose[:, :3, :3]
    return space, x, measurement.Observations(q, points, rot)


def lsq(space, obs, k, x0):
    fit = least_squares(
        lambda v: measurement.residuals(space, v, obs, k), x0, xtol=1e-13, ftol=1e-13, gtol=1e-13
    )
    return fit.x


@pytest.mark.parametrize("dof", [3, 6])
def test_threshold_is_the_bonferroni_chi_square_point(dof):
    for x in (0.5, 3.0, 16.266, 40.0):
        assert robust.chi2_sf(x, dof) == pytest.approx(stats.chi2.sf(x, dof), rel=1e-9)
    for n in (1, 32, 1000, 50_000):
        expected = stats.chi2.isf(robust.FAMILY_ALPHA / n, dof)
        assert robust.threshold(n, dof) == pytest.approx(expected, rel=1e-9)
    # More poses, a higher bar for the worst of them.
    assert robust.threshold(1000, dof) > robust.threshold(32, dof) > robust.threshold(1, dof)
    # A covariance from nu degrees of freedom: Hotelling's T^2, a chi-square as nu grows.
    for n, nu in ((16, 13.0), (40, 37.0), (200, 197.0), (50_000, 49_990.0)):
        d2 = nu - dof + 1
        expected = dof * nu / d2 * stats.f.isf(robust.FAMILY_ALPHA / n, dof, d2)
        assert robust.threshold(n, dof, nu=nu) == pytest.approx(expected, rel=1e-8)
    assert robust.threshold(50_000, dof, nu=1e9) == pytest.approx(robust.threshold(50_000, dof))


def test_truncation_constants_are_the_chi_square_values():
    q = stats.chi2.ppf(0.975, 3)
    assert robust._KEEP_Q3 == pytest.approx(q, abs=1e-4)
    assert robust._KEEP_FACTOR == pytest.approx(stats.chi2.cdf(q, 5) / 0.975, abs=1e-5)


def test_whitener_recovers_an_anisotropic_covariance_despite_outliers():
    rng = np.random.default_rng(7)
    cov = np.array([[4.0, 1.0, 0.0], [1.0, 2.0, 0.3], [0.0, 0.3, 0.25]]) * 1e-4
    v = rng.multivariate_normal(np.zeros(3), cov, 4000)
    v[:100] += rng.normal(0, 1.0, (100, 3))  # 2.5 % gross errors, 100 sigmas
    got = np.linalg.inv(robust.whitener(v))
    np.testing.assert_allclose(got, cov, rtol=0, atol=0.06 * cov.max())
    # Clean vectors whitened by it are chi-square(3): mean 3.
    d2 = np.einsum("ij,jk,ik->i", v[100:], robust.whitener(v), v[100:])
    assert d2.mean() == pytest.approx(3.0, rel=0.05)


def test_robust_scales_are_1_4826_times_the_median_absolute_residual_per_block():
    res = np.array([1.0, -2.0, 3.0, 4.0, -5.0, 6.0, 0.1, -0.1, 0.2, 0.3, 0.0, -0.4])
    scale = robust.robust_scales(res, 2)
    np.testing.assert_allclose(scale[:6], 1.4826 * 3.5, rtol=1e-12)
    np.testing.assert_allclose(scale[6:], 1.4826 * 0.15, rtol=1e-12)
    np.testing.assert_allclose(robust.robust_scales(res[:6], 2), 1.4826 * 3.5, rtol=1e-12)
    # Noise-free data: the scales stop at their floor instead of zero.
    np.testing.assert_array_equal(robust.robust_scales(np.zeros(12), 2), np.full(12, 1e-6))
    tiny = np.r_[np.full(6, 1e-9), np.full(6, 1.0)]
    np.testing.assert_array_equal(robust.robust_scales(tiny, 2)[:6], 1e-6)
    # Position rows only: no orientation block to estimate (not even a warning).
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        np.testing.assert_allclose(robust.robust_scales(res[:6], 2), 1.4826 * 3.5)


@pytest.mark.parametrize("blocks", [1, 2])
def test_outlier_threshold_is_inclusive_just_at_the_bonferroni_point(blocks):
    n = 40
    rng = np.random.default_rng(2)
    res = rng.normal(0, 1.0, (blocks, n, 3))
    res[:, :2] = 0.0
    flat = res.ravel()
    limit = robust.threshold(n, 3 * blocks)
    d2 = robust.distances(flat, n)
    assert d2[2:].max() < limit  # clean: nothing named
    # Pose 1 just outside, pose 0 just inside, along the whitened axes.
    w = robust.whitener(res[0, 2:])  # the zeros of poses 0 and 1 barely move it
    scale = 1.0 / np.sqrt(np.diag(w))
    flat = res.copy()
    flat[0, 0, 0] = scale[0] * np.sqrt(0.99 * limit)
    flat[0, 1, 0] = scale[0] * np.sqrt(1.01 * limit)
    d2 = robust.distances(flat.ravel(), n)
    assert d2[0] < limit < d2[1]
    assert 1 in robust.outliers(flat.ravel(), n).tolist()
    assert 0 not in robust.outliers(flat.ravel(), n).tolist()


def fd_jacobian(space, x, obs, k, h=1e-7):
    cols = []
    for step in np.eye(len(x)) * h:
        plus = measurement.residuals(space, x + step, obs, k)
        minus = measurement.residuals(space, x - step, obs, k)
        cols.append((plus - minus) / (2 * h))
    return np.column_stack(cols)


def huber_gradient(space, x, obs, k, scale):
    """Gradient of sum rho_c(r_i / s_i), relative to the size of its terms, and z."""
    z = measurement.residuals(space, x, obs, k) / scale
    psi = np.clip(z, -1.345, 1.345)  # rho'(z) of Huber's loss with c = 1.345
    js = fd_jacobian(space, x, obs, k) / scale[:, None]
    return np.abs(js.T @ psi) / (np.abs(js).T @ np.abs(psi)), z


def ssr(space, x, obs, k):
    res = measurement.residuals(space, x, obs, k)
    return res @ res


def test_huber_answer_is_a_stationary_point_of_the_huber_loss():
    space, truth, obs = problem(orientation=True)
    x0 = lsq(space, obs, K, np.zeros(len(NAMES)))
    # One round: whitened by the robust scale of the residuals at the start.
    scale0 = robust.robust_scales(measurement.residuals(space, x0, obs, K), len(obs))
    one = robust.huber(Problem.of(space, obs, K), x0, rounds=1)
    grad, z = huber_gradient(space, one.x, obs, K, scale0)
    assert np.all(grad < 1e-3)  # c = 1.2 or 1.5 give 3e-2
    assert np.sum(np.abs(z) > 1.345) > 4  # enough rows beyond c that the corner matters
    # Two rounds: the second is whitened at the first round's answer.
    two = robust.huber(Problem.of(space, obs, K), x0, rounds=2)
    scale1 = robust.robust_scales(measurement.residuals(space, one.x, obs, K), len(obs))
    grad, _ = huber_gradient(space, two.x, obs, K, scale1)
    assert np.all(grad < 1e-3)  # c = 1.2 or 1.5 give 3e-2
    assert not np.allclose(two.x, one.x, rtol=0, atol=1e-6)
    assert two.evaluations > one.evaluations > 1
    # The two bad poses are named, judged at the answer's own robust scale.
    assert two.outliers.tolist() == [5, 11]

    # Least squares is dragged by the bad poses; Huber much less.
    def err(x):
        model = measurement.predict(space, x, obs.q)[:, :3, 3]
        return np.abs(model - measurement.predict(space, truth, obs.q)[:, :3, 3]).max()

    assert err(two.x) < 0.5 * err(x0)


def test_huber_on_clean_data_is_close_to_least_squares_but_not_equal():
    space, _, obs = problem(orientation=False)
    clean = obs.subset(np.delete(np.arange(len(obs)), 5))
    x_lsq = lsq(space, clean, 0.0, np.zeros(len(NAMES)))
    out = robust.huber(Problem.of(space, clean, 0.0), np.zeros(len(NAMES)))
    res = measurement.residuals(space, out.x, clean)
    z = res / robust.robust_scales(res, len(clean))
    assert np.abs(z).max() > 1.345  # some rows are in the linear part ...
    # ... so Huber and least squares differ, but only a little on Gaussian noise.
    assert ssr(space, x_lsq, clean, 0.0) < ssr(space, out.x, clean, 0.0)
    assert ssr(space, out.x, clean, 0.0) < 1.05 * ssr(space, x_lsq, clean, 0.0)
    assert out.outliers.tolist() == []


def test_huber_stops_at_the_evaluation_cap_and_after_converging():
    space, _, obs = problem(orientation=False)
    capped = robust.huber(
        Problem.of(space, obs, 0.0), np.zeros(len(NAMES)), rounds=1, max_evaluations=2
    )
    assert capped.evaluations <= 2
    full = robust.huber(Problem.of(space, obs, 0.0), np.zeros(len(NAMES)), rounds=1)
    assert full.evaluations > 2
    # From its own converged answer the scale no longer changes: one short round.
    settled = robust.huber(Problem.of(space, obs, 0.0), np.zeros(len(NAMES)), rounds=50)
    again = robust.huber(Problem.of(space, obs, 0.0), settled.x, rounds=50)
    assert again.evaluations < 0.5 * settled.evaluations
    np.testing.assert_allclose(again.x, settled.x, rtol=0, atol=1e-7)


@pytest.mark.parametrize("orientation", [False, True])
def test_trimmed_answer_is_least_squares_on_the_poses_it_keeps(orientation):
    space, _, obs = problem(orientation=orientation)
    k = K if orientation else 0.0
    out = robust.trimmed(Problem.of(space, obs, k), np.zeros(len(NAMES)))
    expected = [5, 11] if orientation else [5]
    assert out.outliers.tolist() == expected
    keep = np.setdiff1d(np.arange(len(obs)), expected)
    x = lsq(space, obs.subset(keep), k, np.zeros(len(NAMES)))
    kept = obs.subset(keep)
    assert ssr(space, out.x, kept, k) == pytest.approx(ssr(space, x, kept, k), rel=1e-9)
    np.testing.assert_allclose(out.x, x, rtol=0, atol=1e-5)
    # The set it keeps is exactly what the outlier test passes, with the
    # covariance of each block taken on the kept poses only.
    n = len(obs)
    res = measurement.residuals(space, out.x, obs, k)
    kept_res = res.reshape(-1, n, 3)[:, keep].ravel()
    z = robust.distances(res, n, reference=kept_res)
    limit = stats.chi2.isf(robust.FAMILY_ALPHA / n, len(res) // n)
    assert np.flatnonzero(z > limit).tolist() == expected
    assert out.evaluations > 2


def test_trimmed_with_one_round_keeps_the_first_judgement():
    space, _, obs = problem(orientation=False)
    out = robust.trimmed(Problem.of(space, obs, 0.0), np.zeros(len(NAMES)), rounds=1)
    # One round: the fit is on every pose (dragged), then the poses are judged.
    x_all = lsq(space, obs, 0.0, np.zeros(len(NAMES)))
    assert (
        out.evaluations
        == refine.refine(Problem.of(space, obs, 0.0), np.zeros(len(NAMES))).evaluations
    )
    assert ssr(space, out.x, obs, 0.0) == pytest.approx(ssr(space, x_all, obs, 0.0), rel=1e-9)
    assert 5 in out.outliers.tolist()
