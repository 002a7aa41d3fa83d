"""Standard errors, correlations and predicted held-out error of a fit.

Linearised at the solution: with residual Jacobian ``J`` and the residual
variance of each block (position rows, orientation rows) estimated from the
fit's own residuals, the deltas' covariance is the sandwich

    C = (J^T J)^-1 J^T S J (J^T J)^-1,   S = diag(sigma_block^2)

which is ``sigma^2 (J^T J)^-1`` when both blocks have the same noise. A
held-out pose's predicted position error propagates ``C`` through its
position rows and adds the point noise.

That prediction is proportional to the position sigma, and the root of an
unbiased variance estimate is itself low: by ``c4(nu)`` for ``nu`` residual
degrees of freedom (0.89 at 2, 0.95 at 5, 0.99 at 30). A position-only fit
of few poses has few (10 poses, 25 parameters: 5), so its prediction divides
``c4`` out (:func:`sigma_bias`); the standard errors are left as estimated.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from calibrator.fit_records import CorrelatedPair, Prediction, Uncertainty
from calibrator.model import measurement, parameters

if TYPE_CHECKING:
    from calibrator.identify.problem import Problem
    from calibrator.model.measurement import Observations

#: Pairs of free parameters with ``|correlation|`` above this are named.
STRONG_CORRELATION = 0.9
# E|e| / sqrt(E|e|^2) for an isotropic 3-D Gaussian: sqrt(8 / (3 pi)).
_MEAN_OVER_RMS = float(np.sqrt(8.0 / (3.0 * np.pi)))
#: The same ratio, for other modules' predictions of a mean distance error.
MEAN_OVER_RMS = _MEAN_OVER_RMS


def block_sigmas(
    res: np.ndarray, n_poses: int, n_free: int, jac: np.ndarray | None = None
) -> tuple[float, float | None]:
    """Residual standard deviation per row of each block.

    Parameters
    ----------
    res : ndarray, shape (3N,) or (6N,)
        Residuals at the solution (position rows, then orientation rows).
    n_poses, n_free : int
    jac : ndarray, shape (len(res), n_free), optional
        The residual Jacobian at the solution. With it each block's share of
        the fit is the exact one: ``E[e e^T] = (I-H) S (I-H)`` with ``H`` the
        fit's hat matrix and ``S`` the block variances, solved for them. The
        blocks rarely give up equal shares: with a precise probe the
        orientation rows are nearly noise-free and the position rows absorb
        most of the fit, so an equal split makes the position sigma too small.

    Returns
    -------
    sigma_p : float
        Per position row (mm).
    sigma_o : float or None
        Per weighted orientation row (mm-equivalent, ``sqrt(k)`` rad).
    """
    m = len(res)
    if jac is not None and m > 3 * n_poses:
        exact = _block_sigmas_exact(res, n_poses, jac)
        if exact is not None:
            return exact
    dof = max(1.0 - n_free / m, 1e-3)  # each block gives up its share of the fit
    pos = res[: 3 * n_poses]
    sigma_p = float(np.sqrt(np.sum(pos**2) / (len(pos) * dof)))
    if m == 3 * n_poses:
        return sigma_p, None
    rot = res[3 * n_poses :]
    return sigma_p, float(np.sqrt(np.sum(rot**2) / (len(rot) * dof)))


def _block_sigmas_exact(res, n_poses, jac):
    """Position and orientation sigmas from ``E|e_b|^2 = sum_c A_bc sigma_c^2``, or None."""
    scale = np.linalg.norm(jac, axis=0)
    scale[scale == 0] = 1.0
    q, _ = np.linalg.qr(jac / scale)
    # (I - H)^2 summed by blocks, H = Q Q^T: A_bc = sum_{i in b, j in c} (I - H)_ij^2
    # = delta_bc (|b| - 2 tr G_b) + tr(G_b G_c), G_b = Q_b^T Q_b, without forming
    # the (M, M) hat matrix (M = 6N rows: quadratic memory and time otherwise).
    blocks = (slice(0, 3 * n_poses), slice(3 * n_poses, len(res)))
    g = [np.einsum("mi,mj->ij", q[b], q[b]) for b in blocks]
    sizes = [3 * n_poses, len(res) - 3 * n_poses]
    a = np.array(
        [
            [
                np.sum(g[i] * g[j]) + (sizes[i] - 2.0 * np.trace(g[i]) if i == j else 0.0)
                for j in range(2)
            ]
            for i in range(2)
        ]
    )
    rss = np.array([np.sum(res[b] ** 2) for b in blocks])
    try:
        var = np.linalg.solve(a, rss)
    except np.linalg.LinAlgError:
        return None
    if var[1] <= 0:  # orientation rows at the noise of round-off: all the fit is position's
        var = np.array([rss[0] / a[0, 0], rss[1] / max(a[1, 1], 1e-12)])
    if not var[0] > 0:
        return None
    return float(np.sqrt(var[0])), float(np.sqrt(max(var[1], 0.0)))


def analyse(
    problem: Problem,
    x: np.ndarray,
    validation: Observations | None = None,
    unidentified: Sequence[str] = (),
) -> Uncertainty:
    """Uncertainty of the deltas ``x`` fitted on ``problem``'s poses.

    Parameters
    ----------
    problem : calibrator.identify.problem.Problem
        The poses the fit used (inliers), free set and orientation weight.
    x : ndarray, shape (space.size,)
    validation : calibrator.model.measurement.Observations, optional
        Held-out poses to predict the error at.
    unidentified : sequence of str
        Joint parameters these poses could not identify (left at nominal);
        their prior uncertainty enters the prediction
        (:func:`unidentified_variance`).

    Returns
    -------
    Uncertainty
        ``standard_errors`` {name: value (mm or rad)}, ``correlation``
        {"names", "matrix"} (with the standard errors, the covariance), ``strong_correlations``
        [{"a", "b", "r"}], ``residual_sigma`` {"position_mm",
        "orientation_rad"}, ``position_dof`` (the residual degrees of freedom of the
        position rows, :func:`position_dof`), ``predicted_validation_mm`` (with validation).
    """
    space, k, n = problem.space, problem.k, len(problem)
    names = list(space.free)
    res = problem.residuals(x)
    jac = problem.jacobian(x)
    sigma_p, sigma_o = block_sigmas(res, n, len(names), jac)
    row_var = np.full(len(res), sigma_p**2)
    if sigma_o is not None:
        row_var[3 * n :] = sigma_o**2
    # Columns scaled to unit length before inverting: mm and rad columns differ by 1e3.
    scale = np.linalg.norm(jac, axis=0)
    scale[scale == 0] = 1.0
    js = jac / scale
    # einsum, not BLAS: on a busy 2-core machine threaded BLAS on these tall,
    # narrow products was measured 20-80 times slower than one plain loop.
    bread = np.linalg.pinv(gram(js), rcond=1e-13, hermitian=True)
    meat = gram(js * np.sqrt(row_var)[:, None])
    cov = (bread @ meat @ bread) / np.outer(scale, scale)
    se = np.sqrt(np.maximum(np.diag(cov), 0.0))
    safe = np.where(se > 0, se, 1.0)
    corr = cov / np.outer(safe, safe)
    strong = [
        CorrelatedPair(a=names[i], b=names[j], r=float(corr[i, j]))
        for i in range(len(names))
        for j in range(i + 1, len(names))
        if abs(corr[i, j]) > STRONG_CORRELATION
    ]
    strong.sort(key=lambda p: -abs(p["r"]))
    dof = position_dof(js, n)
    out: Uncertainty = {
        "standard_errors": dict(zip(names, map(float, se), strict=True)),
        "correlation": {"names": names, "matrix": np.round(corr, 6).tolist()},
        "strong_correlations": strong,
        "residual_sigma": {
            "position_mm": sigma_p,
            "orientation_rad": None if sigma_o is None else sigma_o / np.sqrt(k),
        },
        "position_dof": dof,
    }
    if validation is not None and len(validation):
        extra = unidentified_variance(problem, x, out["standard_errors"], validation, unidentified)
        out["predicted_validation_mm"] = predict_error(
            space, x, validation, cov, sigma_p, dof, extra
        )
    return out


def unidentified_variance(
    problem: Problem,
    x: np.ndarray,
    standard_errors: dict,
    obs: Observations,
    names: Sequence[str],
) -> np.ndarray:
    """Position error variance at ``obs`` from the joint parameters the fit left out (mm^2).

    A joint parameter the poses could not identify (its standard error too
    large with them, or redundant with others at these poses only: e.g.
    ``a5`` with few poses; identify names them ``... with these poses``) is
    fixed at its nominal
    value, yet the arm's true one differs by about as much as the identified
    ones do. At the fitted poses the fit absorbs most of that into the free
    parameters; away from them (other joint ranges) it does not. With a prior
    on each left-out parameter (zero mean, the variance of the identified
    joint deltas of its unit less their own estimation variance: empirical
    Bayes), the part of its effect the fit cannot absorb (its Jacobian column
    at ``obs`` less its least-squares projection through the fitted poses'
    free columns) is propagated. A parameter that is redundant with the
    free ones (``d6`` with the tool, ``theta1`` with the base) projects out
    exactly and adds nothing.

    Parameters
    ----------
    problem : calibrator.identify.problem.Problem
        The fit: its free set, poses and orientation weight.
    x : ndarray, shape (space.size,)
    standard_errors : dict
        ``{name: standard error}`` of the free parameters.
    obs : calibrator.model.measurement.Observations
        The poses to predict at.
    names : sequence of str
        The joint parameters left out for these poses (others are ignored).

    Returns
    -------
    ndarray, shape (len(obs),)
        Added variance of the 3-D position error at each pose (mm^2); zeros
        when every joint parameter is identified or none is.
    """
    from calibrator.identify.problem import Problem

    space = problem.space
    free = list(space.free)
    left = [n for n in names if n in parameters.MDH_NAMES and n not in free]
    joint = [n for n in free if n in parameters.MDH_NAMES]
    out = np.zeros(len(obs))
    if not left or not joint:
        return out
    prior = {}
    for unit in ("mm", "rad"):
        same = [n for n in joint if parameters.unit(n) == unit]
        if same:
            spread = [float(x[free.index(n)]) ** 2 - standard_errors[n] ** 2 for n in same]
            prior[unit] = max(float(np.mean(spread)), 0.0)
    left = [n for n in left if prior.get(parameters.unit(n), 0.0) > 0]
    if not left:
        return out
    full = space.with_free(free + left)
    order = list(full.free)
    x_all = np.zeros(full.size)
    x_all[[order.index(n) for n in free]] = x
    fi = [order.index(n) for n in free]
    li = [order.index(n) for n in left]
    at_fit = Problem(full, problem.obs, problem.k).jacobian(x_all)
    at_new = measurement.jacobian(full, x_all, obs, 0.0)[: 3 * len(obs)]
    # Columns scaled to unit length: mm and rad columns differ by 1e3.
    scale = np.linalg.norm(at_fit, axis=0)
    scale[scale == 0] = 1.0
    absorbed = np.linalg.lstsq(at_fit[:, fi] / scale[fi], at_fit[:, li], rcond=1e-12)[0]
    left_over = at_new[:, li] - (at_new[:, fi] / scale[fi]) @ absorbed
    var = np.array([prior[parameters.unit(n)] for n in left])
    blocks = left_over.reshape(len(obs), 3, len(left))
    return np.einsum("nid,d,nid->n", blocks, var, blocks)


def position_dof(jac: np.ndarray, n_poses: int) -> float:
    """Residual degrees of freedom of the position rows: ``3N - tr(H_pp)``.

    Parameters
    ----------
    jac : ndarray, shape (3N or 6N, P)
        The residual Jacobian at the solution (columns in any scale), position
        rows first.
    n_poses : int

    Returns
    -------
    float
        The position rows less their share of the fit (the hat matrix's
        trace over them): ``3N - rank`` without orientation rows.
    """
    q, r = np.linalg.qr(jac)
    # Only the directions the fit really spans (rank-deficient columns add none).
    diag = np.abs(np.diag(r))
    keep = diag > 1e-10 * max(float(diag.max(initial=0.0)), 1e-300)
    share = float(np.sum(q[: 3 * n_poses, keep] ** 2))
    return max(3.0 * n_poses - share, 0.0)


def sigma_bias(dof: float | None) -> float:
    """``c4(nu)``: the expected root of an unbiased variance estimate over the true sigma.

    ``sqrt(2 / nu) Gamma((nu + 1) / 2) / Gamma(nu / 2)``; 1 for None or many
    degrees of freedom; at least that of one degree (0.80).
    """
    if dof is None or dof > 1e4:
        return 1.0
    nu = max(float(dof), 1.0)
    return math.sqrt(2.0 / nu) * math.exp(math.lgamma((nu + 1) / 2) - math.lgamma(nu / 2))


def gram(a: np.ndarray) -> np.ndarray:
    """``a.T @ a`` for a tall, narrow ``a`` (M, D), without threaded BLAS."""
    return np.einsum("mi,mj->ij", a, a)


def predict_error(
    space: parameters.ParameterSpace,
    x: ArrayLike,
    obs: Observations,
    cov: np.ndarray,
    sigma_p: float,
    dof: float | None = None,
    unidentified_var: np.ndarray | None = None,
) -> Prediction:
    """Predicted position error at poses not used in the fit.

    ``dof``, the position rows' residual degrees of freedom
    (:func:`position_dof`), removes the low bias of a sigma estimated from
    few of them (:func:`sigma_bias`) from every figure; ``cov`` and
    ``sigma_p`` are the fit's estimates. ``unidentified_var`` (N,) mm^2 is
    what the joint parameters left out add at each pose
    (:func:`unidentified_variance`).

    Returns
    -------
    Prediction
        ``model_rms_mean``, ``model_rms_max``: RMS position error (mm) that
        the parameters' uncertainty alone causes (the identified ones' and
        the left-out ones'), mean and worst over the poses; ``error_mean``:
        expected mean distance between model and measured point there, noise
        included.
    """
    unbias = 1.0 / sigma_bias(dof)
    sigma_p, cov = sigma_p * unbias, cov * unbias**2
    jac = measurement.jacobian(space, x, obs, 0.0).reshape(len(obs), 3, -1)
    model_var = np.einsum("nid,de,nie->n", jac, cov, jac)
    if unidentified_var is not None:
        model_var = model_var + unidentified_var
    model_rms = np.sqrt(np.maximum(model_var, 0.0))
    total = np.sqrt(model_var + 3 * sigma_p**2)
    return {
        "model_rms_mean": float(model_rms.mean()),
        "model_rms_max": float(model_rms.max()),
        "error_mean": float(_MEAN_OVER_RMS * total.mean()),
        "noise_floor": noise_floor(sigma_p),
    }


def noise_floor_line(unc: Uncertainty) -> str:
    """``noise floor: ...`` for ``identify``'s output."""
    floor = noise_floor(unc["residual_sigma"]["position_mm"])
    return (
        f"noise floor: {floor:.4f} mm mean held-out error from the residual noise alone "
        "(no model predicts better)"
    )


def noise_floor(sigma_p: float) -> float:
    """Mean held-out distance error that the residual noise alone implies (mm).

    ``E|e|`` of an isotropic 3-D Gaussian with ``sigma_p`` per axis: no fit,
    however many poses, predicts better on average.
    """
    return float(_MEAN_OVER_RMS * np.sqrt(3.0) * sigma_p)


def poses_for_target(model_rms_mean: float, n_fit: int, target_mm: float) -> int:
    """More poses of the same kind that bring the parameter part below ``target_mm``.

    The parameters' covariance falls as ``1 / N`` for more poses drawn like the
    fitted ones, so the parameter part of the held-out error as ``1 / sqrt(N)``.

    Returns
    -------
    int
        0 when already below.
    """
    if model_rms_mean <= target_mm:
        return 0
    return int(np.ceil(n_fit * (model_rms_mean / target_mm) ** 2 - n_fit))


#: Poses count as outside the fitted joint ranges beyond this margin: the larger
#: of 2 deg and 10 % of the range.
RANGE_SLACK_RAD = np.radians(2.0)
RANGE_SLACK_SHARE = 0.1


def range_warnings(fit_q: np.ndarray, others: np.ndarray, what: str = "held-out") -> list[str]:
    """A warning when poses lie outside the joint ranges the fit saw.

    Parameters
    ----------
    fit_q : ndarray, shape (N, 6)
        Joint angles of the fitted poses (rad).
    others : ndarray, shape (M, 6)
        Joint angles of the poses to predict at.
    what : str
        What those poses are ('held-out', 'target').

    Returns
    -------
    list of str
        Empty, or one sentence naming how many poses and which joints: the
        model is extrapolated there and its errors grow faster than predicted.
    """
    if len(fit_q) == 0 or len(others) == 0:
        return []
    lo, hi = fit_q.min(axis=0), fit_q.max(axis=0)
    # A step just past the edge is noise of the pose draw, not extrapolation.
    slack = np.maximum(RANGE_SLACK_RAD, RANGE_SLACK_SHARE * (hi - lo))
    outside = (others < lo - slack) | (others > hi + slack)
    if not outside.any():
        return []
    joints = [j + 1 for j in range(6) if outside[:, j].any()]
    worst = np.max(np.maximum(lo - others, others - hi), axis=0)
    parts = ", ".join(f"q{j} by up to {np.degrees(worst[j - 1]):.1f} deg" for j in joints)
    n = int(outside.any(axis=1).sum())
    return [
        f"{n} of {len(others)} {what} poses lie outside the fitted joint ranges ({parts}): "
        "the model is extrapolated there; expect larger errors than predicted"
    ]


def summary_lines(unc: Uncertainty, limit: int = 6) -> list[str]:
    """A short text summary: worst standard errors and correlated pairs."""
    se = unc["standard_errors"]
    lines = []
    if se:
        top = sorted(se, key=lambda n: -se[n] / parameters.plausible_range(n))[:limit]
        parts = ", ".join(f"{n} {_fmt(n, se[n])}" for n in top)
        lines.append(f"standard errors (largest relative to range): {parts}")
    sig = unc["residual_sigma"]
    text = f"residual sigma: {sig['position_mm']:.4f} mm per axis"
    if sig["orientation_rad"] is not None:
        text += f", {np.degrees(sig['orientation_rad']):.4f} deg"
    lines.append(text)
    strong = unc["strong_correlations"]
    if strong:
        pairs = ", ".join(f"{p['a']}/{p['b']} {p['r']:+.2f}" for p in strong[:limit])
        more = f" and {len(strong) - limit} more" if len(strong) > limit else ""
        lines.append(f"strongly correlated (|r| > {STRONG_CORRELATION}): {pairs}{more}")
    pred = unc.get("predicted_validation_mm")
    if pred:
        lines.append(
            f"predicted held-out position error: mean {pred['error_mean']:.4f} mm "
            f"(parameter part {pred['model_rms_mean']:.4f} mm RMS, worst "
            f"{pred['model_rms_max']:.4f} mm)"
        )
    return lines


def _fmt(name, value):
    if parameters.unit(name) not in ("mm", "rad"):  # joint terms: 1, rad/Nm
        return f"{value:.3g} {parameters.unit(name)}"
    if parameters.unit(name) == "rad":
        return f"{np.degrees(value) * 1000:.3g} mdeg"
    return f"{value * 1000:.3g} um"
