"""Predicted held-out error off the fitted poses: leverage, the noise per block, extrapolation."""

import numpy as np
import pytest
from joint_kit import sessions

from calibrator import session
from calibrator.identify import pipeline, uncertainty
from calibrator.model import joint_terms, measurement

#: An arm with an error the geometric model does not hold (joint compliance).
UNMODELLED = joint_terms.JointTerms(
    np.zeros(6), np.zeros(6), np.zeros(6), np.array([0, 2e-6, 3e-6, 0, 0, 0])
)


def _first10_last20(seed, terms, narrow):
    """Fit the first 10 of 30 poses, check on the last 20: (predicted, observed) mean mm."""
    parts, _ = sessions(
        terms, poses=30, seed=seed, noise_mm=0.05, payloads_kg=(5.0,), narrow_first=narrow
    )
    full = parts[0][0]
    first = session.Session(full.table.slice(0, 10), full.meta)
    options = pipeline.Options(method="lm", validation_fraction=0.0, noise_mm=0.05)
    result = pipeline.identify(first, options)
    rest = full.observations.subset(np.arange(10, 30))
    unc = result.uncertainty
    se = np.array([unc["standard_errors"][n] for n in result.space.free])
    cov = np.array(unc["correlation"]["matrix"]) * np.outer(se, se)
    sigma = unc["residual_sigma"]["position_mm"]
    predicted = uncertainty.predict_error(result.space, result.x, rest, cov, sigma)
    position, _ = measurement.errors(result.space, result.x, rest)
    return predicted["error_mean"], float(np.linalg.norm(position, axis=1).mean())


@pytest.mark.parametrize(
    ("terms", "narrow"),
    [
        # The real data's case: errors the model lacks, first poses in a narrower range.
        (UNMODELLED, (10, 0.6)),
        # A geometric arm, random order.
        (joint_terms.JointTerms.zero(), None),
    ],
)
def test_first_10_last_20_prediction_is_within_20_percent(terms, narrow):
    """Pooled over ten simulated arms and noise draws (one split is one noisy sample)."""
    runs = np.array([_first10_last20(seed, terms, narrow) for seed in range(10)])
    ratio = runs[:, 0].mean() / runs[:, 1].mean()
    assert 0.8 <= ratio <= 1.2, (ratio, runs)


def test_block_sigmas_split_the_fit_by_rows_not_equally():
    """Precise orientation rows: the position rows carry the fit's degrees of freedom."""
    rng = np.random.default_rng(0)
    n, d = 40, 20
    jac = rng.normal(size=(6 * n, d))
    true = np.r_[np.full(3 * n, 0.03), np.full(3 * n, 0.001)]
    ests = []
    for _ in range(200):
        eps = rng.normal(size=6 * n) * true
        q, _ = np.linalg.qr(jac)
        res = eps - q @ (q.T @ eps)
        ests.append(uncertainty.block_sigmas(res, n, d, jac)[0] ** 2)
    assert np.mean(ests) == pytest.approx(0.03**2, rel=0.05)


def test_noise_floor_and_poses_for_a_target():
    assert uncertainty.noise_floor(0.05) == pytest.approx(np.sqrt(8 / (3 * np.pi)) * 0.05 * 3**0.5)
    assert uncertainty.poses_for_target(0.02, 30, 0.01) == 90  # 4x the poses halve it
    assert uncertainty.poses_for_target(0.01, 30, 0.02) == 0


def test_poses_outside_the_fitted_ranges_are_named():
    fit_q = np.zeros((5, 6))
    fit_q[:, 1] = np.linspace(-1, 1, 5)
    others = np.zeros((3, 6))
    others[0, 1] = 1.5
    others[1, 1] = 1.15  # within the 10 % margin
    (line,) = uncertainty.range_warnings(fit_q, others, "target")
    assert line.startswith("1 of 3 target poses") and "q2 by up to 28.6 deg" in line
    assert uncertainty.range_warnings(fit_q, np.zeros((2, 6))) == []
