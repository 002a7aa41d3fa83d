"""The tolerance budget against an independent linearisation (finite differences) and Monte Carlo.

Everything here is computed from :func:`calibrator.model.kinematics.chain` alone:
the Jacobian by central differences of the hand pose, the nonlinear check by
perturbing the table with this file's own random draws.
"""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from calibrator import robots
from calibrator.analysis import tolerance as tl
from calibrator.errors import CalibrationError
from calibrator.model import kinematics

MDH = robots.get("ur10e").mdh
Q = np.random.default_rng(21).uniform(-np.pi, np.pi, (8, 6))
N_LINK = 30


def displacement(nominal, real):
    """Rotation vector of ``R_nom^T R`` and ``R_nom^T (p - p_nom)``, shape (..., N, 6)."""
    r_nom = nominal[:, :3, :3]
    rel = np.swapaxes(r_nom, -1, -2) @ real[..., :3, :3]
    rot = Rotation.from_matrix(rel.reshape(-1, 3, 3)).as_rotvec().reshape(rel.shape[:-1])
    pos = np.einsum("nji,...nj->...ni", r_nom, real[..., :3, 3] - nominal[:, :3, 3])
    return np.concatenate([rot, pos], axis=-1)


def hand_displacement(mdh, q, dev):
    """Hand displacement (hand frame) for deviation sets ``dev``, shape (M, 36) -> (M, N, 6).

    A joint deviation turns the joint, which is what a theta deviation does.
    """
    tables = mdh + dev[:, :N_LINK].reshape(-1, 6, 5)
    tables[:, :, kinematics.THETA] += dev[:, N_LINK:]
    return displacement(kinematics.chain(mdh, q), kinematics.chain(tables, q))


def fd_jacobian(mdh, q, step=1e-6):
    """Central differences of the hand displacement, shape (N, 6, 36); joints through q."""
    nominal = kinematics.chain(mdh, q)
    cols = []
    for j in range(N_LINK):
        e = np.zeros(N_LINK)
        e[j] = step
        tables = mdh + np.stack([e, -e]).reshape(2, 6, 5)
        plus, minus = displacement(nominal, kinematics.chain(tables, q))
        cols.append((plus - minus) / (2 * step))
    for i in range(6):
        e = np.zeros(6)
        e[i] = step
        plus = displacement(nominal, kinematics.chain(mdh, q + e))
        minus = displacement(nominal, kinematics.chain(mdh, q - e))
        cols.append((plus - minus) / (2 * step))
    return np.stack(cols, axis=-1)


def expected_budget(jac, t, sigma):
    """The linear budget's numbers, from a Jacobian, by their definitions."""
    pos, rot = jac[:, 3:], jac[:, :3]
    norm = np.linalg.norm(pos, axis=1)  # (N, 36)
    contrib = np.mean(norm**2 * sigma**2, axis=0)
    joint = np.array([n.startswith("q") for n in tl.NAMES])
    return {
        "worst_case_mm": np.max(norm @ t),
        "worst_case_axis_mm": np.max(np.abs(pos) @ t),
        "rms_mm": np.sqrt(contrib.sum()),
        "link_only_rms_mm": np.sqrt(contrib[~joint].sum()),
        "joint_only_rms_mm": np.sqrt(contrib[joint].sum()),
        "orientation_rms_deg": np.degrees(
            np.sqrt(np.mean(np.sum(np.linalg.norm(rot, axis=1) ** 2 * sigma**2, axis=1)))
        ),
        "contrib": contrib,
        "worst_mm": np.mean(norm * t, axis=0),
    }


def test_hand_jacobian_is_the_finite_difference_jacobian():
    np.testing.assert_allclose(tl.hand_jacobian(MDH, Q), fd_jacobian(MDH, Q), atol=2e-6)


def uneven_tolerances(distribution):
    """Different tolerances per kind and some overrides, so every column weighs differently."""
    overrides = {"a2": 0.1, "d4": 0.01, "beta3": np.radians(0.05), "q2": np.radians(0.03)}
    return tl.Tolerances.build(
        0.05, np.radians(0.01), np.radians(0.02), overrides, distribution=distribution
    )


@pytest.mark.parametrize("distribution, sigma_per_t", [("uniform", 3**-0.5), ("normal", 1 / 3)])
def test_budget_equals_its_definitions_on_a_finite_difference_jacobian(distribution, sigma_per_t):
    given = uneven_tolerances(distribution)
    result = tl.budget(MDH, Q, given, samples=200, seed=3)
    # beta entries between non-parallel axes are no quantity of this arm: no tolerance.
    excluded = tl.without_meaning(MDH)
    assert "beta3" not in excluded and {"beta1", "beta6"} <= set(excluded)
    tol = tl.for_arm(given, MDH)
    assert all(tol.t[tl.NAMES.index(n)] == 0 for n in excluded)
    want = expected_budget(fd_jacobian(MDH, Q), tol.t, sigma_per_t * tol.t)
    for key in (
        "worst_case_mm",
        "worst_case_axis_mm",
        "rms_mm",
        "link_only_rms_mm",
        "joint_only_rms_mm",
        "orientation_rms_deg",
    ):
        assert result[key] == pytest.approx(want[key], rel=1e-6), key
    assert result["poses"] == len(Q) and result["distribution"] == distribution
    assert 0.0 < result["nonlinear"]["linearisation_error"] < 1e-3
    total = want["contrib"].sum()
    order = [row["name"] for row in result["ranking"]]
    assert sorted(order) == sorted(n for n in tl.NAMES if n not in excluded)
    assert [d["name"] for d in result["not_toleranced"]] == list(excluded)
    shares = [want["contrib"][tl.NAMES.index(n)] / total for n in order]
    # Decreasing (to the finite differences' precision).
    assert all(a >= b * (1 - 1e-6) for a, b in zip(shares, shares[1:], strict=False))
    for row in result["ranking"]:
        j = tl.NAMES.index(row["name"])
        assert row["tolerance"] == tol.t[j]
        assert row["unit"] == ("mm" if row["name"][0] in "ad" and row["name"][1] != "l" else "rad")
        assert row["share"] == pytest.approx(want["contrib"][j] / total, rel=1e-6, abs=1e-15)
        assert row["rms_mm"] == pytest.approx(np.sqrt(want["contrib"][j]), rel=1e-6, abs=1e-12)
        assert row["worst_mm"] == pytest.approx(want["worst_mm"][j], rel=1e-6, abs=1e-12)


def test_nonlinear_check_agrees_with_an_independent_monte_carlo():
    # Loose tolerances, so the second-order remainder is well above round-off.
    tol = tl.Tolerances.build(1.0, np.radians(0.5), np.radians(0.5))
    result = tl.budget(MDH, Q, tol, samples=1500, seed=5)["nonlinear"]
    dev = np.random.default_rng(99).uniform(-1.0, 1.0, (1500, len(tl.NAMES))) * tol.t
    exact = hand_displacement(MDH, Q, dev)
    linear = np.einsum("nkj,mj->mnk", fd_jacobian(MDH, Q), dev)
    r = np.linalg.norm(exact[..., 3:], axis=-1)
    rms = np.sqrt(np.mean(r**2))
    remainder = np.sqrt(np.mean(np.sum((linear[..., 3:] - exact[..., 3:]) ** 2, axis=-1)))
    assert result["samples"] == 1500
    assert result["rms_mm"] == pytest.approx(rms, rel=0.05)
    assert result["p95_mm"] == pytest.approx(np.quantile(r, 0.95), rel=0.05)
    assert np.quantile(r, 0.99) < result["max_mm"] < 1.3 * r.max()
    assert result["linearisation_error"] == pytest.approx(remainder / rms, rel=0.1)
    assert 1e-4 < result["linearisation_error"] < 0.05


def test_sub_millimetre_errors_still_have_a_linearisation_error():
    tol = tl.Tolerances.build(0.01, 1e-5, 1e-5)
    nonlinear = tl.budget(MDH, Q[:3], tol, samples=50)["nonlinear"]
    assert 0.0 < nonlinear["max_mm"] < 0.1
    assert 0.0 < nonlinear["linearisation_error"] < 1e-3


def test_budget_is_reproducible_from_its_seed():
    tol = uneven_tolerances("normal")
    a = tl.budget(MDH, Q[:3], tol, samples=50, seed=7)
    b = tl.budget(MDH, Q[:3], tol, samples=50, seed=7)
    c = tl.budget(MDH, Q[:3], tol, samples=50, seed=8)
    assert a == b
    assert a["nonlinear"] != c["nonlinear"]


def test_zero_tolerances_give_zero_error_and_no_division_by_zero():
    result = tl.budget(MDH, Q[:2], tl.Tolerances.build(0.0, 0.0, 0.0), samples=20)
    for key in ("worst_case_mm", "worst_case_axis_mm", "rms_mm", "orientation_rms_deg"):
        assert result[key] == 0.0
    assert result["nonlinear"] == {
        "samples": 20,
        "rms_mm": 0.0,
        "p95_mm": 0.0,
        "max_mm": 0.0,
        "linearisation_error": 0.0,
    }
    physical = [n for n in tl.NAMES if n not in tl.without_meaning(MDH)]
    assert [row["share"] for row in result["ranking"]] == [0.0] * len(physical)
    assert [row["name"] for row in result["ranking"]] == physical


def test_ties_in_the_ranking_keep_the_table_order():
    tol = tl.Tolerances.build(0.0, 0.0, 0.0, {"a2": 0.1, "q3": 1e-4})
    ranking = [row["name"] for row in tl.budget(MDH, Q[:3], tol, samples=10)["ranking"]]
    assert set(ranking[:2]) == {"a2", "q3"}
    unranked = ("a2", "q3", *tl.without_meaning(MDH))
    assert ranking[2:] == [n for n in tl.NAMES if n not in unranked]


def test_build_gives_each_kind_its_tolerance():
    tol = tl.Tolerances.build(0.05, 1e-4, 2e-4, {"alpha3": 3e-4, "d6": 0.5})
    for name, t in zip(tl.NAMES, tol.t, strict=True):
        if name == "alpha3":
            assert t == 3e-4
        elif name == "d6":
            assert t == 0.5
        elif name.startswith("q"):
            assert t == 2e-4
        elif name[0] in "ad" and not name.startswith("alpha"):
            assert t == 0.05
        else:
            assert t == 1e-4
    assert [n for n in tl.NAMES if tl.is_length(n)] == [
        f"{k}{i}" for i in range(1, 7) for k in "ad"
    ]


def test_integer_tolerances_keep_fractional_overrides():
    tol = tl.Tolerances.build(0, 0, 0, {"a2": 0.02})
    assert tol.t[tl.NAMES.index("a2")] == 0.02


@pytest.mark.parametrize("distribution", ["uniform", "normal"])
def test_samples_follow_the_distribution(distribution):
    tol = tl.Tolerances.build(0.3, 0.002, 0.001, distribution=distribution)
    assert isinstance(tol.t, np.ndarray) and tol.t.dtype == float
    draws = tol.sample(np.random.default_rng(4), 20000)
    assert draws.shape == (20000, 36)
    np.testing.assert_allclose(draws.std(axis=0), tol.sigma, rtol=0.05)
    assert np.all(np.abs(draws.mean(axis=0)) < 0.05 * tol.t)
    inside = np.abs(draws) <= tol.t
    if distribution == "uniform":
        np.testing.assert_allclose(tol.sigma, tol.t / np.sqrt(3))
        assert inside.all()
    else:
        np.testing.assert_allclose(tol.sigma, tol.t / 3)
        assert 0.995 < inside.mean() < 0.999  # 3 sigma: 0.27 % outside


def test_tolerances_from_a_plain_list():
    tol = tl.Tolerances([0.1] * 36, "normal")
    assert isinstance(tol.t, np.ndarray)
    np.testing.assert_allclose(tol.sigma, np.full(36, 0.1 / 3))


@pytest.mark.parametrize(
    "t, distribution, message",
    [
        (np.full(35, 0.1), "uniform", "tolerances must be 36 finite values >= 0"),
        (np.full((6, 6), 0.1), "uniform", "tolerances must be 36 finite values >= 0"),
        (np.r_[np.full(35, 0.1), np.nan], "uniform", "tolerances must be 36 finite values >= 0"),
        (np.r_[np.full(35, 0.1), -1e-9], "uniform", "tolerances must be 36 finite values >= 0"),
        (np.full(36, 0.1), "cauchy", "unknown distribution 'cauchy'; known: uniform, normal"),
    ],
)
def test_bad_tolerances_are_refused(t, distribution, message):
    with pytest.raises(CalibrationError) as info:
        tl.Tolerances(t, distribution)
    assert str(info.value) == message


def test_unknown_override_names_the_known_parameters():
    with pytest.raises(CalibrationError) as info:
        tl.Tolerances.build(0.05, 1e-4, 1e-4, {"a7": 0.1})
    assert str(info.value).startswith("unknown parameter 'a7'; known: a1, alpha1, theta1, d1,")
    assert str(info.value).endswith("beta6, q1, q2, q3, q4, q5, q6")
