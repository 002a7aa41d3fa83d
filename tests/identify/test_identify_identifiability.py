"""What the poses can identify, checked on Jacobians whose answer is known by hand.

Each test builds a small Jacobian (orthogonal or exactly collinear columns,
chosen norms) so the standard errors, the dropped parameters and the
condition number follow from a line of arithmetic, independent of the
eigen-decomposition the module uses.
"""

import warnings

import numpy as np
import pytest

from calibrator import robots
from calibrator.errors import IdentifiabilityError
from calibrator.identify import identifiability as idf
from calibrator.identify.problem import Problem
from calibrator.model import measurement, parameters

# Plausible ranges (see calibrator.model.parameters.PLAUSIBLE): a1 1 mm, alpha1 0.01 rad,
# base_tx 5 mm, base_rx 0.02 rad.
NAMES = ["a1", "alpha1", "base_tx", "base_rx"]
RANGES = np.array([1.0, 0.01, 5.0, 0.02])


def orthogonal_jacobian(norms, rows=8):
    """Columns along distinct unit axes, scaled to ``norms``: J^T J = diag(norms^2)."""
    jac = np.zeros((rows, len(norms)))
    for i, n in enumerate(norms):
        jac[i, i] = n
    return jac


def test_scaled_information_is_s_jt_j_s_over_noise_squared():
    rng = np.random.default_rng(1)
    jac = rng.normal(size=(12, 4))
    noise = 0.2
    s = np.diag(RANGES)
    expected = s @ jac.T @ jac @ s / noise**2
    np.testing.assert_allclose(idf.scaled_information(jac, NAMES, noise), expected, rtol=1e-12)


def test_gram_is_the_plain_product():
    a = np.arange(12.0).reshape(4, 3) - 5.0
    np.testing.assert_allclose(idf.uncertainty.gram(a), a.T @ a, rtol=0, atol=1e-12)


def test_relative_errors_of_a_regular_information_are_its_inverse():
    rng = np.random.default_rng(2)
    a = rng.normal(size=(10, 3)) * [1.0, 30.0, 0.05]  # badly scaled on purpose
    info = a.T @ a
    se, cov = idf.relative_errors(info)
    inv = np.linalg.inv(info)
    np.testing.assert_allclose(cov, inv, rtol=1e-9)
    np.testing.assert_allclose(se, np.sqrt(np.diag(inv)), rtol=1e-9)


def test_a_weak_but_not_null_direction_keeps_a_finite_error():
    # Eigenvalue ratio 1e-10: above the 1e-12 null threshold, so still inverted.
    c, s = np.cos(0.3), np.sin(0.3)
    v = np.array([[c, -s], [s, c]])
    info = v @ np.diag([1.0, 1e-10]) @ v.T
    se, cov = idf.relative_errors(info)
    np.testing.assert_allclose(cov, np.linalg.inv(info), rtol=1e-4)
    assert np.all(np.isfinite(se))
    assert se[0] == pytest.approx(np.sqrt(np.linalg.inv(info)[0, 0]), rel=1e-4)


def test_parameters_in_a_null_direction_are_undetermined_the_others_not():
    # Columns 0 and 1 identical (only their sum is seen), column 2 on its own.
    jac = np.zeros((6, 3))
    jac[0, 0] = jac[0, 1] = 2.0
    jac[1, 0] = jac[1, 1] = 1.0
    jac[2, 2] = 4.0
    se, cov = idf.relative_errors(jac.T @ jac)
    assert np.isinf(se[0]) and np.isinf(se[1])
    assert se[2] == pytest.approx(0.25, rel=1e-12)  # 1 / column norm
    assert cov[2, 2] == pytest.approx(1 / 16, rel=1e-12)


def test_the_null_part_of_the_covariance_is_the_pseudo_inverse_without_warnings():
    # Columns 0 and 1 identical: the normalised information is [[1, 1], [1, 1]]
    # there, whose pseudo-inverse is 1/4 everywhere; scaled back by the column
    # norm squared (5), 0.05. No division by the zero eigenvalue, not even a warning.
    jac = np.zeros((4, 3))
    jac[0, :2] = 2.0
    jac[1, :2] = 1.0
    jac[2, 2] = 4.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        se, cov = idf.relative_errors(jac.T @ jac)
    np.testing.assert_allclose(cov[:2, :2], np.full((2, 2), 0.05), rtol=1e-9)
    np.testing.assert_allclose(cov[:2, 2], 0.0, atol=1e-15)
    assert np.isinf(se[:2]).all()


def test_the_null_threshold_is_relative_to_the_largest_eigenvalue():
    # Unit diagonal, correlation c: eigenvalues 1 - c and 1 + c (about 2); the
    # threshold is 1e-12 times the largest, so 2e-12.
    def se_of(gap):
        c = 1.0 - gap
        return idf.relative_errors(np.array([[1.0, c], [c, 1.0]]))[0]

    assert np.isinf(se_of(1.5e-12)).all()
    assert np.isfinite(se_of(3e-12)).all()


def test_a_parameter_with_tiny_but_regular_information_is_finite():
    # Normalised by the diagonal, the information is the identity: nothing is null
    # however small one parameter's information is in absolute terms.
    se, cov = idf.relative_errors(np.diag([1.0, 1e-13]))
    np.testing.assert_allclose(se, [1.0, np.sqrt(1e13)], rtol=1e-12)


def test_a_column_with_no_effect_is_undetermined():
    jac = orthogonal_jacobian([3.0, 0.0, 2.0])
    se, _ = idf.relative_errors(jac.T @ jac)
    assert np.isinf(se[1])
    np.testing.assert_allclose(se[[0, 2]], [1 / 3, 1 / 2], rtol=1e-12)


def test_select_keeps_errors_at_the_threshold_and_drops_just_above():
    noise = 0.05
    # se_i (range units) = noise / (norm_i * range_i): 0.1, 0.299, 0.301, 0.2
    target = np.array([0.1, 0.299, 0.301, 0.2])
    jac = orthogonal_jacobian(noise / (target * RANGES))
    kept, dropped = idf.select(NAMES, jac, noise)
    assert kept == ["a1", "alpha1", "base_rx"]
    assert [d["name"] for d in dropped] == ["base_tx"]
    se_mm = 0.301 * 5.0
    assert dropped[0]["reason"] == (
        f"standard error {se_mm:.3g} mm with these poses (at 0.05 mm noise; a kept "
        "parameter needs at most 0.3 x its plausible 5 mm)"
    )


def test_select_threshold_argument_is_used():
    noise = 0.05
    target = np.array([0.1, 0.15, 0.25, 0.2])
    jac = orthogonal_jacobian(noise / (target * RANGES))
    kept, dropped = idf.select(NAMES, jac, noise, threshold=0.18)
    assert kept == ["a1", "alpha1"]
    assert [d["name"] for d in dropped] == ["base_tx", "base_rx"]  # worst first
    assert "at most 0.18 x its plausible 0.02 rad" in dropped[1]["reason"]
    assert "standard error 0.004 rad" in dropped[1]["reason"]  # 0.2 * 0.02 rad


def test_select_drops_the_worst_of_a_confounded_pair_and_then_keeps_the_other():
    noise = 0.01
    rows = 6
    jac = np.zeros((rows, 2))
    # a1 and d1 (both 1 mm ranges) almost collinear: each alone is well determined.
    jac[:, 0] = [1.0, 1.0, 0, 0, 0, 0]
    jac[:, 1] = [1.0, 1.001, 0, 0, 0, 0]
    kept, dropped = idf.select(["a1", "d1"], jac, noise)
    assert len(kept) == 1 and len(dropped) == 1
    info = idf.scaled_information(jac, ["a1", "d1"], noise)
    se_both = np.sqrt(np.diag(np.linalg.inv(info)))
    worst = int(np.argmax(se_both))
    assert dropped[0]["name"] == ["a1", "d1"][worst]
    # The partner is named with its |cos| computed from the columns.
    cos = abs(jac[:, 0] @ jac[:, 1]) / np.linalg.norm(jac[:, 0]) / np.linalg.norm(jac[:, 1])
    assert dropped[0]["reason"].endswith(f", confounded with {kept[0]} (cos {cos:.3f})")
    assert f"standard error {se_both[worst]:.3g} mm with these poses" in dropped[0]["reason"]


def test_select_names_an_undetermined_parameter_and_one_with_no_effect():
    noise = 0.05
    jac = orthogonal_jacobian([1.0, 0.0, 1.0], rows=4)
    kept, dropped = idf.select(["a1", "d1", "base_tx"], jac, noise)
    assert kept == ["a1", "base_tx"]
    assert dropped[0]["name"] == "d1"
    assert dropped[0]["reason"].startswith("not determined by these poses (at 0.05 mm noise")
    assert dropped[0]["reason"].endswith(", no effect on these poses")


def test_select_keeps_an_error_exactly_at_the_threshold():
    # Scaled information (1 mm x 1 / 0.5 mm)^2 = 4: the standard error is 0.5 exactly.
    assert idf.select(["a1"], np.array([[1.0]]), 0.5, threshold=0.5) == (["a1"], [])
    assert idf.select(["a1"], np.array([[1.0]]), 0.5, threshold=0.4999)[0] == []


def test_select_calls_a_million_ranges_undetermined():
    def reason(se):  # a1 alone, range 1 mm, noise 1 mm: se = 1 / column
        return idf.select(["a1"], np.array([[1.0 / se]]), 1.0)[1][0]["reason"]

    assert reason(0.999999e6).startswith("standard error 1e+06 mm with these poses")
    assert reason(1.0000005e6).startswith("not determined by these poses")


def test_select_drops_everything_when_nothing_is_seen():
    kept, dropped = idf.select(["a1"], np.zeros((3, 1)), 0.05)
    assert kept == []
    # Alone: no partner to name.
    assert dropped[0]["reason"].endswith("its plausible 1 mm)")


def test_most_correlated_below_half_names_no_partner():
    # cos between the two columns exactly 0.5: not above, so no partner.
    info = np.array([[1.0, 0.5], [0.5, 1.0]])
    assert idf._most_correlated(info, 0, ["a", "b"]) == ""
    info = np.array([[4.0, 2.02], [2.02, 4.0]])  # cos 0.505
    assert idf._most_correlated(info, 1, ["a", "b"]) == ", confounded with a (cos 0.505)"
    info = np.array([[1.0, -0.9, 0.1], [-0.9, 1.0, 0.6], [0.1, 0.6, 1.0]])
    assert idf._most_correlated(info, 1, ["a", "b", "c"]) == ", confounded with a (cos 0.900)"


def test_condition_number_is_that_of_the_range_scaled_jacobian():
    rng = np.random.default_rng(3)
    jac = rng.normal(size=(20, 4)) * [1.0, 10.0, 0.1, 3.0]
    info = idf.scaled_information(jac, NAMES, 0.05)
    expected = np.linalg.cond(jac * RANGES / 0.05)
    assert idf.condition_number(info) == pytest.approx(expected, rel=1e-8)
    assert idf.condition_number(np.diag([4.0, 1.0])) == pytest.approx(2.0, rel=1e-12)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert idf.condition_number(np.diag([4.0, 0.0])) == float("inf")
        # Round-off can make a singular information's smallest eigenvalue negative.
        assert idf.condition_number(np.diag([4.0, -1e-18])) == float("inf")


def test_duplicate_poses_are_the_later_copies_within_the_grid():
    tol = idf.DUPLICATE_RAD
    q = np.zeros((6, 6))
    q[1] = 1.0  # distinct
    q[2] = 0.4 * tol  # rounds onto pose 0's bin: a repeat
    q[3] = 1.0  # repeat of pose 1
    q[4] = 0.6 * tol  # the next bin: distinct
    q[5] = q[4]
    q[5, 3] -= 2 * tol  # another joint differs: distinct
    np.testing.assert_array_equal(idf.duplicate_poses(q), [2, 3])
    assert idf.duplicate_poses(q, tol=10 * tol).tolist() == [2, 3, 4, 5]  # one coarse bin
    assert idf.duplicate_poses(q[:2]).tolist() == []


def test_session_warnings_at_their_boundaries():
    assert idf.session_warnings(18, 6, 1e3, []) == []  # 3 values per parameter, cond 1e3
    assert idf.session_warnings(5, 0, 0.0, []) == []
    out = idf.session_warnings(17, 6, 1000.5, [4, 9])
    assert out == [
        "only 17 measured values for 6 free parameters (2.8 per parameter, fewer than 3): "
        "the fit may not predict unseen poses; measure more poses",
        "2 pose(s) repeat another pose's joint angles within 0.001 rad; they add no information",
        "condition number 1e+03 of the scaled Jacobian is above 1000: some parameter "
        "combinations are poorly determined (see the strongly correlated pairs)",
    ]


def test_require_some_refuses_an_empty_free_set_only():
    idf.require_some(["a1"])
    with pytest.raises(IdentifiabilityError) as err:
        idf.require_some([])
    assert str(err.value) == (
        "these poses cannot identify any parameter: measure distinct, well-spread poses"
    )


@pytest.mark.parametrize("k", [0.0, 1.0e4])
def test_jacobian_on_is_the_derivative_at_the_first_guess(k):
    robot = robots.get("er10l-c10")
    free = ("a2", "d3", "theta4", "base_tx", "tool_rx")
    names = ["a2", "theta4", "tool_rx"]  # the columns asked for, a subset of the free
    space = parameters.ParameterSpace(robot.mdh, free=free)
    q = np.random.default_rng(4).uniform(-2, 2, (5, 6))
    # Measured turns equal to the model's: the orientation rows' derivative is exact there.
    rot = measurement.predict(space, np.zeros(len(free)), q)[:, :3, :3]
    obs = measurement.Observations(q, np.zeros((5, 3)), rot)
    jac = Problem.of(space, obs, k).jacobian(np.zeros(len(free)), names=names)
    assert jac.shape == (30 if k else 15, 3)
    h = 1e-6
    for i, name in enumerate(names):
        step = np.zeros(len(free))
        step[free.index(name)] = h
        fd = (
            measurement.residuals(space, step, obs, k) - measurement.residuals(space, -step, obs, k)
        ) / (2 * h)
        np.testing.assert_allclose(jac[:, i], fd, rtol=1e-5, atol=1e-5)
