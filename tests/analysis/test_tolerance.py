"""Tolerance budget: the linear map against the full kinematics, worst case, ranking."""

import numpy as np
import pytest

from calibrator import robots
from calibrator.analysis import tolerance as tl
from calibrator.errors import CalibrationError

MDH = robots.get("er10l-c10").mdh
Q = np.random.default_rng(4).uniform(-np.pi, np.pi, (15, 6))


def test_linear_prediction_converges_to_the_nonlinear_model():
    dp0 = tl.Tolerances.build(0.1, np.radians(0.05), np.radians(0.05)).sample(
        np.random.default_rng(1), 40
    )
    jac = tl.hand_jacobian(MDH, Q)
    errors = []
    for scale in (1.0, 0.1, 0.01):
        dp = dp0 * scale
        exact = tl.nonlinear_displacement(MDH, Q, dp)
        linear = np.einsum("nkj,mj->mnk", jac, dp)
        errors.append(np.linalg.norm(linear - exact) / np.linalg.norm(exact))
    # Second-order remainder: the relative error shrinks with the deviation.
    assert errors[0] < 1e-2
    assert errors[1] < errors[0] / 5 and errors[2] < errors[1] / 5


def test_joint_deviation_is_the_theta_column():
    jac = tl.hand_jacobian(MDH, Q)
    for i in range(6):
        np.testing.assert_array_equal(
            jac[..., tl.NAMES.index(f"q{i + 1}")], jac[..., tl.NAMES.index(f"theta{i + 1}")]
        )
    # A d slide moves the hand without turning it, by exactly one mm per mm.
    col = jac[..., tl.NAMES.index("d1")]
    np.testing.assert_allclose(col[:, :3], 0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(col[:, 3:], axis=1), 1.0)


@pytest.mark.parametrize("distribution", ["uniform", "normal"])
def test_budget_worst_case_and_statistics_hold_on_the_nonlinear_model(distribution):
    tol = tl.Tolerances.build(0.05, np.radians(0.01), np.radians(0.01), None, distribution)
    result = tl.budget(MDH, Q, tol, samples=3000, seed=2)
    nl = result["nonlinear"]
    assert nl["max_mm"] <= result["worst_case_mm"]
    assert nl["rms_mm"] == pytest.approx(result["rms_mm"], rel=0.05)
    assert nl["linearisation_error"] < 1e-3
    shares = [row["share"] for row in result["ranking"]]
    assert shares == sorted(shares, reverse=True) and sum(shares) == pytest.approx(1.0)
    total = result["link_only_rms_mm"] ** 2 + result["joint_only_rms_mm"] ** 2
    assert total == pytest.approx(result["rms_mm"] ** 2)


def test_tightening_the_top_parameter_helps_most():
    tol = tl.Tolerances.build(0.05, np.radians(0.01), np.radians(0.01))
    result = tl.budget(MDH, Q, tol, samples=10)
    top, last = result["ranking"][0]["name"], result["ranking"][-1]["name"]
    rms = {
        name: tl.budget(
            MDH, Q, tl.Tolerances.build(0.05, *[np.radians(0.01)] * 2, {name: 0.0}), samples=10
        )["rms_mm"]
        for name in (top, last)
    }
    assert rms[top] < rms[last] <= result["rms_mm"]


def test_bad_tolerances():
    with pytest.raises(CalibrationError, match="unknown parameter 'a7'"):
        tl.Tolerances.build(0.05, 1e-4, 1e-4, {"a7": 0.1})
    with pytest.raises(CalibrationError, match="unknown distribution"):
        tl.Tolerances.build(0.05, 1e-4, 1e-4, None, "cauchy")
    with pytest.raises(CalibrationError, match=">= 0"):
        tl.Tolerances.build(-0.05, 1e-4, 1e-4)
