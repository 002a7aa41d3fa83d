"""Our Levenberg-Marquardt stops at scipy's optimum, and says honestly how it stopped.

The reference is ``scipy.optimize.least_squares(method="lm", x_scale="jac")``
with the tolerances ``refine`` used to pass it (1e-14), the fit ``identify``
ran before :mod:`calibrator.identify.levmar` replaced it. The problems:
identify problems made from simulated sessions (with noise and without, a
tracker frame metres from the base mixing mm, rad and metre-scale offsets),
Meyer's badly scaled exponential, a rank-deficient free set and an
ill-conditioned one. Where a problem has a residual, the costs agree to
1e-9 relative and the parameters to a tiny fraction of their standard
errors; where it has none (noise-free data), both costs are at the
round-off floor and the parameters agree in absolute terms.
"""

import numpy as np
import pytest
from scipy.optimize import least_squares

from calibrator import robots, session
from calibrator.identify import levmar, pipeline, refine
from calibrator.identify.problem import Problem
from calibrator.model import measurement, parameters
from calibrator.simulate import simulate


def scipy_lm(fun, x0, jac, max_nfev=200):
    return least_squares(
        fun,
        x0,
        jac=jac,
        method="lm",
        x_scale="jac",
        xtol=1e-14,
        ftol=1e-14,
        gtol=1e-14,
        max_nfev=max_nfev,
    )


def standard_errors(jac, cost):
    """Per-parameter standard errors at an optimum, from ``(J^T J)^-1 cost / (m - n)``."""
    m, n = jac.shape
    return np.sqrt(np.diag(np.linalg.inv(jac.T @ jac)) * cost / (m - n))


def identify_problem(tmp_path, **simulation):
    """The least-squares problem ``identify`` builds from a simulated session."""
    table, meta, truth = simulate(**simulation)
    path = tmp_path / "session.parquet"
    session.write(path, table, meta)
    loaded = session.load(path)
    # The swarm hardly runs: only the problem (free set, frames' first guess) is wanted.
    found = pipeline.identify(loaded, pipeline.Options(method="pso", generations=1, particles=4))
    fit = loaded.observations.subset(found.fit_index)
    problem = Problem.of(found.space, fit, found.k)
    return problem, problem.space.pack(truth.mdh, truth.base2tracker, truth.flange2tool)


ER10L = dict(model="er10l-c10", poses=32, seed=3, frame="base", orientation=True, errors="ref003")
UR10E = dict(
    model="ur10e",
    poses=40,
    seed=21,
    frame="tracker",
    noise_mm=0.03,
    orientation_noise_rad=np.radians(0.005),
    errors="random",
    tool_offset_mm=8.0,
)


@pytest.mark.parametrize("start", ["zero", "near the truth"])
def test_noisy_identify_problem_reaches_scipys_optimum(tmp_path, start):
    problem, truth = identify_problem(tmp_path, noise_mm=0.02, **ER10L)
    x0 = problem.zero()
    if start != "zero":
        x0 = truth + np.random.default_rng(1).normal(0, 1e-3, truth.size)
    ref = scipy_lm(problem.residuals, x0, problem.jacobian)
    ours = levmar.levenberg_marquardt(problem.residuals, x0, problem.jacobian)
    assert ours.converged and ref.status > 0
    assert ours.cost == pytest.approx(2 * ref.cost, rel=1e-9)
    se = standard_errors(problem.jacobian(ref.x), 2 * ref.cost)
    assert np.max(np.abs(ours.x - ref.x) / se) < 1e-6
    np.testing.assert_array_equal(ours.fun, problem.residuals(ours.x))


def test_noise_free_identify_problem_reaches_the_truth_like_scipy(tmp_path):
    problem, truth = identify_problem(tmp_path, noise_mm=0.0, **ER10L)
    ref = scipy_lm(problem.residuals, problem.zero(), problem.jacobian)
    ours = levmar.levenberg_marquardt(problem.residuals, problem.zero(), problem.jacobian)
    # No residual left: both at the round-off floor (mm^2), which no relative test can compare.
    assert 2 * ref.cost < 1e-18 and ours.cost < 1e-18
    np.testing.assert_allclose(ours.x, ref.x, rtol=0, atol=1e-10)
    np.testing.assert_allclose(ours.x, truth, rtol=0, atol=1e-9)


@pytest.mark.parametrize("orientation", [False, True])
def test_tracker_frame_metres_away_mixing_mm_and_rad_reaches_scipys_optimum(tmp_path, orientation):
    problem, _ = identify_problem(tmp_path, orientation=orientation, **UR10E)
    # Badly scaled on purpose: the base frame is metres away, so a base turn (rad)
    # moves the points thousands of times more than an MDH length (mm).
    assert np.linalg.norm(problem.space.base0[:3, 3]) > 2000
    cols = np.linalg.norm(problem.jacobian(problem.zero()), axis=0)
    assert cols.max() / cols.min() > 500
    ref = scipy_lm(problem.residuals, problem.zero(), problem.jacobian)
    ours = levmar.levenberg_marquardt(problem.residuals, problem.zero(), problem.jacobian)
    assert ours.cost == pytest.approx(2 * ref.cost, rel=1e-9)
    se = standard_errors(problem.jacobian(ref.x), 2 * ref.cost)
    assert np.max(np.abs(ours.x - ref.x) / se) < 1e-6


def test_refine_is_the_same_fit_on_the_identify_problem(tmp_path):
    problem, _ = identify_problem(tmp_path, noise_mm=0.02, **ER10L)
    ours = levmar.levenberg_marquardt(problem.residuals, problem.zero(), problem.jacobian)
    fitted = refine.refine(problem, problem.zero())
    np.testing.assert_array_equal(fitted.x, ours.x)
    assert (
        fitted.cost == ours.cost == float(problem.residuals(fitted.x) @ problem.residuals(fitted.x))
    )
    assert fitted.evaluations == ours.evaluations
    assert fitted.message == ours.message and "satisfied" in fitted.message


# Meyer's function (More, Garbow and Hillstrom 1981, problem 10): parameters of
# size 1e-2, 1e3 and 1e2 and Jacobian columns whose norms differ by 1e4 to 1e5.
MEYER_T = 45.0 + 5.0 * np.arange(16)
MEYER_Y = np.array(
    [34780, 28610, 23650, 19630, 16370, 13720, 11540, 9744]
    + [8261, 7030, 6005, 5147, 4427, 3820, 3307, 2872],
    dtype=float,
)


def meyer(x):
    return x[0] * np.exp(x[1] / (MEYER_T + x[2])) - MEYER_Y


def meyer_jac(x):
    e = np.exp(x[1] / (MEYER_T + x[2]))
    u = MEYER_T + x[2]
    return np.column_stack([e, x[0] * e / u, -x[0] * x[1] * e / u**2])


def test_badly_scaled_meyer_function_reaches_its_known_minimum_like_scipy():
    x0 = np.array([0.02, 4000.0, 250.0])
    cols = np.linalg.norm(meyer_jac(x0), axis=0)
    assert cols.max() / cols.min() > 1e4
    ref = scipy_lm(meyer, x0, meyer_jac, max_nfev=2000)
    ours = levmar.levenberg_marquardt(meyer, x0, meyer_jac, max_evaluations=2000)
    assert ours.converged
    # The published minimum is 87.9458 (sum of squares).
    assert ours.cost == pytest.approx(87.9458551, rel=1e-8)
    assert ours.cost == pytest.approx(2 * ref.cost, rel=1e-9)
    np.testing.assert_allclose(ours.x, ref.x, rtol=1e-8)


def small_problem(names, q, noise_mm, seed):
    """Position-only problem on ER10L-C10 joint angles ``q`` with the given free names."""
    space = parameters.ParameterSpace(robots.get("er10l-c10").mdh, free=names)
    rng = np.random.default_rng(seed)
    x = rng.normal(0, 0.02, len(names))
    points = measurement.predict(space, x, q)[:, :3, 3] + rng.normal(0, noise_mm, (len(q), 3))
    return Problem.of(space, measurement.Observations(q, points, None), 0.0)


def test_rank_deficient_free_set_reaches_scipys_cost_and_identifiable_parts():
    # theta1 and base_rz both turn about the base z axis: only their sum shows.
    q = np.random.default_rng(5).uniform(-1.5, 1.5, (12, 6))
    problem = small_problem(("a2", "theta1", "base_rz", "d4", "base_tx", "tool_x"), q, 0.05, 5)
    sv = np.linalg.svd(problem.jacobian(problem.zero()), compute_uv=False)
    assert sv[-1] < 1e-12 * sv[0]
    ref = scipy_lm(problem.residuals, problem.zero(), problem.jacobian)
    ours = levmar.levenberg_marquardt(problem.residuals, problem.zero(), problem.jacobian)
    assert ours.converged and np.all(np.isfinite(ours.x))
    assert ours.cost == pytest.approx(2 * ref.cost, rel=1e-9)
    theta1, base_rz = (problem.space.free.index(n) for n in ("theta1", "base_rz"))
    rest = np.setdiff1d(np.arange(problem.space.size), [theta1, base_rz])
    assert ours.x[theta1] + ours.x[base_rz] == pytest.approx(
        ref.x[theta1] + ref.x[base_rz], abs=1e-10
    )
    np.testing.assert_allclose(ours.x[rest], ref.x[rest], rtol=0, atol=1e-9)
    # The minimum-norm Gauss-Newton step splits the sum evenly from an even start.
    assert ours.x[theta1] == pytest.approx(ours.x[base_rz], abs=1e-12)


def test_ill_conditioned_free_set_reaches_scipys_optimum():
    # Eight poses within 0.1 rad of one another: condition number near 1e6.
    q = np.random.default_rng(5).uniform(-0.05, 0.05, (8, 6)) + 0.3
    names = ("a2", "alpha2", "d3", "a3", "d4", "theta5", "base_tx", "base_ty", "base_rz")
    problem = small_problem(names, q, 0.01, 6)
    sv = np.linalg.svd(problem.jacobian(problem.zero()), compute_uv=False)
    assert sv[0] / sv[-1] > 1e5
    ref = scipy_lm(problem.residuals, problem.zero(), problem.jacobian)
    ours = levmar.levenberg_marquardt(problem.residuals, problem.zero(), problem.jacobian)
    assert ours.cost == pytest.approx(2 * ref.cost, rel=1e-9)
    # At a condition number of 1e6 the cost is flat to round-off over a few
    # millionths of a standard error: both fits stop somewhere in there (scipy's
    # gradient test is 1e-7 from zero there, ours 1e-9).
    se = standard_errors(problem.jacobian(ref.x), 2 * ref.cost)
    assert np.max(np.abs(ours.x - ref.x) / se) < 1e-5
    assert gradient_cosine(problem, ours.x) < 1e-8


def gradient_cosine(problem, x):
    """Largest cosine between the residuals and a Jacobian column (0 at a stationary point)."""
    f, jac = problem.residuals(x), problem.jacobian(x)
    return np.max(np.abs(jac.T @ f) / (np.linalg.norm(jac, axis=0) * np.linalg.norm(f)))


class Counted:
    """A function that counts its calls."""

    def __init__(self, fun):
        self.fun, self.calls = fun, 0

    def __call__(self, x):
        self.calls += 1
        return self.fun(x)


@pytest.mark.parametrize("limit", [1, 2, 5, 20])
def test_never_evaluates_more_than_max_evaluations_and_says_so(limit):
    fun, jac = Counted(meyer), Counted(meyer_jac)
    out = levmar.levenberg_marquardt(
        fun, np.array([0.02, 4000.0, 250.0]), jac, max_evaluations=limit
    )
    # Meyer needs about a hundred evaluations: every limit here stops it.
    assert out.evaluations == fun.calls == limit
    assert out.jacobians == jac.calls
    assert out.status == "max_evaluations" and not out.converged
    assert f"limit of {limit} residual evaluations" in out.message
    # The answer is the best point evaluated, with its own residuals.
    np.testing.assert_array_equal(out.fun, meyer(out.x))
    assert (
        out.cost
        == float(out.fun @ out.fun)
        <= float(meyer(np.array([0.02, 4000.0, 250.0])) @ meyer(np.array([0.02, 4000.0, 250.0])))
    )


def test_a_converged_fit_counts_every_evaluation():
    fun, jac = Counted(meyer), Counted(meyer_jac)
    out = levmar.levenberg_marquardt(
        fun, np.array([0.02, 4000.0, 250.0]), jac, max_evaluations=2000
    )
    assert out.converged and out.status in ("ftol", "xtol", "ftol+xtol", "gtol")
    assert out.evaluations == fun.calls and out.jacobians == jac.calls
    assert 1 < out.evaluations < 2000


def test_refine_reports_the_evaluation_limit_in_its_fit_result(tmp_path):
    problem, _ = identify_problem(tmp_path, noise_mm=0.02, **ER10L)
    fitted = refine.refine(problem, problem.zero(), max_evaluations=3)
    assert fitted.evaluations == 3
    assert fitted.message.startswith("stopped before converging")
    assert fitted.cost == pytest.approx(
        float(problem.residuals(fitted.x) @ problem.residuals(fitted.x)), rel=1e-15
    )
    assert fitted.record()["message"] == fitted.message


def log(x):
    with np.errstate(invalid="ignore"):
        return np.log(x)


def test_a_step_into_non_finite_residuals_is_rejected_not_taken():
    # log is not defined below 0: the first Gauss-Newton step from 50 lands at -95.
    fun = Counted(lambda x: log(x) - 1.0)
    out = levmar.levenberg_marquardt(fun, np.array([50.0]), lambda x: np.array([[1.0 / x[0]]]))
    assert np.isnan(fun.fun(np.array([50.0 + 50.0 * (1 - np.log(50.0))])))
    assert out.converged
    assert out.x[0] == pytest.approx(np.e, rel=1e-12)


def test_zero_residual_at_the_start_stops_at_once():
    fun = Counted(lambda x: x - 1.0)
    out = levmar.levenberg_marquardt(fun, np.ones(3), lambda x: np.eye(3))
    assert out.status == "gtol" and out.evaluations == fun.calls == 1 and out.cost == 0.0


@pytest.mark.parametrize(
    ("x0", "limit", "match"),
    [([np.nan], 10, "start"), ([-1.0], 10, "residuals at the start"), ([1.0], 0, "at least 1")],
)
def test_bad_input_is_refused(x0, limit, match):
    with pytest.raises(ValueError, match=match):
        levmar.levenberg_marquardt(
            log, np.array(x0), lambda x: 1 / x[:, None], max_evaluations=limit
        )
