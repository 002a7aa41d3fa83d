"""The predicted held-out error holds for position-only fits of few poses, as for 6-DoF ones.

A position-only fit of 9 poses (27 rows, about 25 parameters) estimates its
noise from about 2 residual degrees of freedom; the root of that unbiased
variance estimate is low by ``c4(2) = 0.89`` on average, and the predicted
error with it. Pooled over 40 simulated arms (tracker frame, unknown base
and tool, 9 of 30 poses fitted, the other 21 held out) the prediction now
agrees with the observed held-out error within 10 % for both kinds of probe;
before the correction the position-only prediction was 14 % low.
"""

import numpy as np
import pytest

from calibrator import simulate
from calibrator.identify import pipeline, uncertainty
from calibrator.session import Session


def _predicted_and_observed(seed, orientation):
    table, meta, _ = simulate.simulate(
        "ur10e", poses=30, seed=seed, frame="tracker", orientation=orientation, noise_mm=0.05,
        orientation_noise_rad=5e-5 if orientation else 0.0, errors="random", tool_offset_mm=1.5,
    )  # fmt: skip
    options = pipeline.Options(method="lm", validation_fraction=0.7, noise_mm=0.05)
    result = pipeline.identify(Session(table, meta), options)
    predicted = result.uncertainty["predicted_validation_mm"]["error_mean"]
    return predicted, result.stats["validation"]["after"]["position_mm"]["mean"]


@pytest.mark.parametrize("orientation", [False, True], ids=["position-only", "6-DoF"])
def test_few_pose_predictions_agree_with_the_held_out_error(orientation):
    runs = np.array([_predicted_and_observed(seed, orientation) for seed in range(40)])
    ratio = runs[:, 0].mean() / runs[:, 1].mean()
    assert 0.9 <= ratio <= 1.1, ratio


def test_position_dof_is_the_rows_less_the_fits_share():
    rng = np.random.default_rng(0)
    jac = rng.normal(size=(27, 25))
    assert uncertainty.position_dof(jac, 9) == pytest.approx(2.0)
    jac[:, 24] = jac[:, 23]  # a parameter the others already hold spans nothing new
    assert uncertainty.position_dof(jac, 9) == pytest.approx(3.0)
    # With orientation rows the position rows carry only their share of the fit.
    six = rng.normal(size=(54, 25))
    q, _ = np.linalg.qr(six)
    assert uncertainty.position_dof(six, 9) == pytest.approx(27 - np.sum(q[:27] ** 2))


def test_sigma_bias_is_c4():
    assert uncertainty.sigma_bias(2) == pytest.approx(np.sqrt(np.pi) / 2)  # c4(2) = 0.8862
    assert uncertainty.sigma_bias(5) == pytest.approx(0.9515, abs=1e-4)
    assert uncertainty.sigma_bias(None) == 1.0
    # The Monte Carlo mean of the root of a chi-square estimate agrees.
    rng = np.random.default_rng(1)
    s = np.sqrt(rng.chisquare(3, 200_000) / 3)
    assert s.mean() == pytest.approx(uncertainty.sigma_bias(3), abs=3e-3)
