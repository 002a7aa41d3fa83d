"""Fits that a few bad poses cannot drag: Huber, trimmed, and the outlier test.

The outlier test asks whether the worst of N poses fits worse than the
worst of N clean poses would. A pose's squared error is its residual
vector's squared Mahalanobis distance, position (3 rows) and with
orientation data the weighted orientation (3 more), under a covariance
fitted to the residuals themselves: a tracker's noise is not the same along
its beam as across it, and grows with range, so one scale for every axis
over-weights the noisy axes and the far poses. Points in the tracker frame
are therefore first turned into each pose's beam frame and scaled by the
tracker noise model's shape at its range (:func:`beam_axes`). Each residual
is divided by the part of the noise the fit leaves in it (its leverage).
The covariance is a reweighted robust estimate (start from
``1.4826 * median(|residual|)`` on every axis, keep the poses inside the
97.5 % chi-square point, re-estimate with the truncation's consistency
factor), so the test is not blinded by the outliers it looks for. Under
that noise model the distance of a clean pose is Hotelling's T^2 (the
covariance comes from N poses less the fit's share of them; a chi-square
with 3 or 6 degrees of freedom for many poses); a pose is an outlier when
its distance exceeds the ``1 - FAMILY_ALPHA / N`` quantile (Bonferroni).
Clean data of any size then warns in at most about ``FAMILY_ALPHA`` of
sessions, where a fixed per-pose quantile warns more often the more poses a
session has, and the more often the fewer poses estimate the noise.
"""

from __future__ import annotations

import math

import numpy as np

from calibrator.identify import refine
from calibrator.identify.problem import FitResult, Problem

#: Chance that the outlier test names any pose of a clean session (family-wise).
FAMILY_ALPHA = 0.001
#: Chi-square 97.5 % point for 3 degrees of freedom: poses beyond it are left out
#: of the covariance estimate.
_KEEP_Q3 = 9.3484
#: E[d^2 | d^2 <= _KEEP_Q3] / 3 for a chi-square with 3 degrees of freedom
#: (``chi2.cdf(q, 5) / chi2.cdf(q, 3)``): the truncated covariance's shrinkage.
_KEEP_FACTOR = 0.92723
#: Fewest poses whose residuals fit a full 3 x 3 covariance; fewer fit a variance
#: per axis (in the beam frame, where the test whitens tracker-frame points, the
#: noise's own axes).
MIN_POSES_FOR_SHAPE = 30
#: Least share of its noise a pose's residual is taken to keep (leverage below 1).
_MIN_KEEP = 0.05
#: Huber's tuning constant (95 % efficiency under Gaussian noise), in sigmas.
HUBER_C = 1.345
_MAD = 1.4826
_FLOOR_MM = 1e-6  # robust scales never below a micrometre's fraction: noise-free data


def robust_scales(res: np.ndarray, n_poses: int) -> np.ndarray:
    """Robust per-row scale of the position block and of the orientation block.

    Returns
    -------
    ndarray, shape (len(res),)
        The scale of each row's block.
    """
    scale = np.empty(len(res))
    pos = res[: 3 * n_poses]
    scale[: 3 * n_poses] = max(_MAD * np.median(np.abs(pos)), _FLOOR_MM)
    if len(res) > 3 * n_poses:
        rot = res[3 * n_poses :]
        scale[3 * n_poses :] = max(_MAD * np.median(np.abs(rot)), _FLOOR_MM)
    return scale


def chi2_sf(x: float, dof: int) -> float:
    """Chi-square survival function ``P(X > x)`` for 3 or 6 degrees of freedom.

    Closed forms (no scipy import at start-up): with 3 degrees of freedom
    ``erfc(sqrt(x/2)) + sqrt(2x/pi) exp(-x/2)``, with 6
    ``exp(-x/2) (1 + x/2 + x^2/8)``.
    """
    if x <= 0:
        return 1.0
    if dof == 3:
        return math.erfc(math.sqrt(x / 2)) + math.sqrt(2 * x / math.pi) * math.exp(-x / 2)
    if dof == 6:
        return math.exp(-x / 2) * (1 + x / 2 + x * x / 8)
    raise ValueError(f"dof must be 3 or 6, got {dof}")


def hotelling_sf(x: float, dof: int, nu: float) -> float:
    """``P(T^2 > x)`` for Hotelling's T^2 of ``dof`` dimensions, covariance from ``nu`` degrees.

    ``T^2 = dof nu / (nu - dof + 1) F(dof, nu - dof + 1)``: the squared distance
    of a clean vector whitened by a covariance estimated from ``nu`` degrees of
    freedom (a chi-square as ``nu`` grows; heavier-tailed for few poses).
    """
    if x <= 0:
        return 1.0
    d2 = nu - dof + 1
    f = x * d2 / (dof * nu)
    return _betainc(d2 / 2, dof / 2, d2 / (d2 + dof * f))


def _betainc(a: float, b: float, x: float) -> float:
    """Regularized incomplete beta ``I_x(a, b)`` (continued fraction, modified Lentz)."""
    if x <= 0.0:
        return 0.0
    if x >= 1.0:
        return 1.0
    front = math.exp(
        math.lgamma(a + b) - math.lgamma(a) - math.lgamma(b) + a * math.log(x) + b * math.log1p(-x)
    )
    if x > (a + 1) / (a + b + 2):  # the fraction converges fast on this side only
        return 1.0 - _betainc(b, a, 1.0 - x)
    tiny = 1e-300
    c, d = 1.0, 1.0 - (a + b) * x / (a + 1)
    d = 1.0 / (d if abs(d) > tiny else tiny)
    h = d
    for m in range(1, 300):
        for num in (
            m * (b - m) * x / ((a + 2 * m - 1) * (a + 2 * m)),
            -(a + m) * (a + b + m) * x / ((a + 2 * m) * (a + 2 * m + 1)),
        ):
            d = 1.0 + num * d
            d = 1.0 / (d if abs(d) > tiny else tiny)
            c = 1.0 + num / c
            c = c if abs(c) > tiny else tiny
            h *= d * c
        if abs(d * c - 1.0) < 1e-15:
            break
    return front * h / a


def threshold(
    n_poses: int, dof: int, alpha: float = FAMILY_ALPHA, nu: float | None = None
) -> float:
    """Squared distance the largest of ``n_poses`` clean ones exceeds with chance ``alpha``.

    The Bonferroni bound: the ``1 - alpha / n_poses`` quantile of a chi-square,
    or with ``nu`` of Hotelling's T^2 (:func:`hotelling_sf`), which allows for
    a covariance estimated from few poses.

    Parameters
    ----------
    n_poses : int
    dof : {3, 6}
        Residual rows per pose (position, or position and orientation).
    alpha : float
        Family-wise false-alarm chance.
    nu : float, optional
        Degrees of freedom of the covariance estimate (at least ``dof``).

    Returns
    -------
    float
        Squared whitened distance (dimensionless).
    """
    if nu is None:
        sf = lambda x: chi2_sf(x, dof)  # noqa: E731
    else:
        sf = lambda x: hotelling_sf(x, dof, max(float(nu), dof))  # noqa: E731
    target = alpha / max(int(n_poses), 1)
    lo, hi = 0.0, 1.0
    while sf(hi) > target:
        lo, hi = hi, 2 * hi
    for _ in range(60):  # bisection to double precision
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if sf(mid) > target else (lo, mid)
    return hi


def whitener(vectors: np.ndarray) -> np.ndarray:
    """Inverse of a robust covariance of residual vectors.

    Parameters
    ----------
    vectors : ndarray, shape (N, 3)
        One block's residual per pose (mm, or weighted orientation units).

    Returns
    -------
    ndarray, shape (3, 3)
        ``W`` such that ``v @ W @ v`` is a clean pose's chi-square(3) distance.
    """
    vectors = np.asarray(vectors, dtype=float)
    scale = max(_MAD * float(np.median(np.abs(vectors))), _FLOOR_MM)
    cov = np.eye(3) * scale**2
    for _ in range(3):
        d2 = np.einsum("ij,jk,ik->i", vectors, np.linalg.inv(cov), vectors)
        kept = vectors[d2 <= _KEEP_Q3]
        if len(kept) < 3:
            break
        cov = kept.T @ kept / (len(kept) * _KEEP_FACTOR)
        if len(kept) < MIN_POSES_FOR_SHAPE:
            # Too few poses for the axes' correlations: their variances only.
            cov = np.diag(np.diag(cov))
        # The floor keeps noise-free data (or a flat residual cloud) invertible.
        cov = cov + np.eye(3) * _FLOOR_MM**2
    return np.linalg.inv(cov)


def _whiten(res: np.ndarray, n_poses: int, reference: np.ndarray) -> np.ndarray:
    """Per pose, its blocks' residuals whitened by the reference's covariances: (N, 3B)."""
    blocks = len(res) // (3 * n_poses)
    per_block = res.reshape(blocks, n_poses, 3)
    ref_blocks = reference.reshape(blocks, -1, 3)
    lowers = [np.linalg.cholesky(whitener(b)) for b in ref_blocks]  # W = L L^T
    return np.concatenate([b @ low for b, low in zip(per_block, lowers, strict=True)], axis=1)


def _studentize(white: np.ndarray, jacobian: np.ndarray, lowers_of) -> np.ndarray:
    """Divide out each pose's leverage: ``(I - H_ii)^(-1/2) r_i`` (whitened rows)."""
    n, width = white.shape
    blocks = width // 3
    per_block = jacobian.reshape(blocks, n, 3, -1)
    jw = np.concatenate(
        [np.einsum("ji,njp->nip", low, jb) for jb, low in zip(per_block, lowers_of, strict=True)],
        axis=1,
    )  # (N, 3B, P): pose i's whitened rows
    u, sv, _ = np.linalg.svd(jw.reshape(n * width, -1), full_matrices=False)
    basis = u[:, sv > sv[0] * 1e-10].reshape(n, width, -1) if sv.size and sv[0] > 0 else None
    if basis is None:
        return white
    keep = np.eye(width) - basis @ basis.transpose(0, 2, 1)  # I - H_ii, (N, 3B, 3B)
    values, vectors = np.linalg.eigh(keep)
    # A pose that alone pins a parameter keeps almost none of its noise: do not blow it up.
    values = np.maximum(values, _MIN_KEEP)
    inv_root = np.einsum("nij,nj,nkj->nik", vectors, 1.0 / np.sqrt(values), vectors)
    return np.einsum("nij,nj->ni", inv_root, white)


def beam_axes(points_mm: np.ndarray) -> np.ndarray:
    """Each point's beam frame scaled by the tracker's noise there: (N, 3, 3).

    Rows: along the beam and two axes across it (:func:`calibrator.model.noise.beam_frame`),
    each divided by the standard deviation the tracker noise model gives at
    that range (:data:`calibrator.model.noise.TRACKER_NOISE`: a laser tracker's
    MPE, a constant plus a part growing with range, smaller along the beam
    than across it). Only the model's shape matters: the outlier test fits
    the covariance of the transformed residuals, so the overall scale and
    the along/across ratio are still estimated from the data.

    Parameters
    ----------
    points_mm : ndarray, shape (N, 3)
        Measured points in the tracker frame (the tracker at the origin), mm.
    """
    from calibrator.model.noise import TRACKER_NOISE, beam_frame  # the tracker model's own

    out = []
    for p in np.asarray(points_mm, dtype=float):
        along, across = TRACKER_NOISE.sigmas_mm(p)
        out.append(np.array(beam_frame(p)) / np.array([[along], [across], [across]]))
    return np.array(out)


def _to_beams(rows: np.ndarray, n_poses: int, axes: np.ndarray) -> np.ndarray:
    """Position rows (the first 3N of ``rows``, any trailing shape) turned into each beam frame."""
    out = np.array(rows, dtype=float)
    pos = out[: 3 * n_poses].reshape(n_poses, 3, -1)
    out[: 3 * n_poses] = np.einsum("nij,njk->nik", axes, pos).reshape(out[: 3 * n_poses].shape)
    return out


def distances(
    res: np.ndarray,
    n_poses: int,
    reference: np.ndarray | None = None,
    jacobian: np.ndarray | None = None,
    beams: np.ndarray | None = None,
) -> np.ndarray:
    """Each pose's squared whitened error, summed over its blocks.

    Parameters
    ----------
    res : ndarray, shape (3N,) or (6N,)
        Residuals: N position rows ``(x, y, z)`` per pose, then as many
        weighted orientation rows.
    n_poses : int
        N.
    reference : ndarray, shape (3M,) or (6M,), optional
        Residuals the covariance is estimated from (the inliers', for a
        trimmed fit); default ``res``.
    jacobian : ndarray, shape (len(res), P), optional
        Of ``res`` at the fit. Given, each pose's residual is divided by the
        part of the noise the fit leaves in it (its leverage: a pose the fit
        leans on keeps less of its noise), so every clean pose has the same
        distribution; the covariance is then re-estimated from these.
    beams : ndarray, shape (N, 3, 3), optional
        :func:`beam_axes` of the measured points, when they are in the
        tracker frame: the position residuals are then whitened along and
        across each pose's own beam and scaled to its range, since a
        tracker's noise is set by the beam (its direction and length change
        from pose to pose), not by the frame's axes.

    Returns
    -------
    ndarray, shape (N,)
        Chi-square with 3 (6) degrees of freedom for clean poses.
    """
    if beams is not None and reference is None:
        res = _to_beams(res, n_poses, beams)
        if jacobian is not None:
            jacobian = _to_beams(jacobian, n_poses, beams)
    ref = res if reference is None else reference
    white = _whiten(res, n_poses, ref)
    if jacobian is not None and reference is None:
        blocks = white.shape[1] // 3
        lowers = [np.linalg.cholesky(whitener(b)) for b in ref.reshape(blocks, -1, 3)]
        student = _studentize(white, np.asarray(jacobian, dtype=float), lowers)
        # The leverage-free vectors, in the first whitening's units: fit their covariance.
        again = student.reshape(n_poses, blocks, 3).transpose(1, 0, 2).ravel()
        white = _whiten(again, n_poses, again)
    return np.sum(white**2, axis=1)


def outliers(
    res: np.ndarray,
    n_poses: int,
    reference: np.ndarray | None = None,
    jacobian: np.ndarray | None = None,
    beams: np.ndarray | None = None,
    alpha: float = FAMILY_ALPHA,
) -> np.ndarray:
    """Poses fitting worse than the worst of ``n_poses`` clean ones would (module docstring).

    Parameters
    ----------
    res : ndarray, shape (3N,) or (6N,)
    n_poses : int
    reference, jacobian, beams : ndarray, optional
        See :func:`distances`.
    alpha : float
        Family-wise false-alarm chance on clean data.

    Returns
    -------
    ndarray of int
    """
    d2 = distances(res, n_poses, reference, jacobian, beams)
    blocks = len(res) // (3 * n_poses)
    nu = None
    if jacobian is not None and reference is None:
        # Each axis's variance is estimated from N poses less its share of the fit.
        nu = n_poses - np.shape(jacobian)[1] / (3 * blocks)
    return np.flatnonzero(d2 > threshold(n_poses, 3 * blocks, alpha, nu))


def huber(
    problem: Problem, x0: np.ndarray, rounds: int = 3, max_evaluations: int = 200
) -> FitResult:
    """Huber M-estimate: quadratic within ``HUBER_C`` robust sigmas, linear beyond.

    The rows are whitened by their block's robust scale, re-estimated after
    each round from the previous round's residuals.

    Returns
    -------
    FitResult
        ``cost``: sum of squared residuals over every fitting pose;
        ``outliers``: poses the outlier test rejects at the solution.
    """
    # Imported here, not at module level: scipy.optimize costs about half a second of
    # start-up, which a run that never reaches this fit (pso, plan, report) must not pay.
    from scipy.optimize import least_squares

    x = np.asarray(x0, dtype=float)
    n = len(problem)
    evaluations = 0
    for _ in range(rounds):
        scale = robust_scales(problem.residuals(x), n)
        fit = least_squares(
            lambda v, s=scale: problem.residuals(v) / s,
            x,
            jac=lambda v, s=scale: problem.jacobian(v) / s[:, None],
            method="trf",
            loss="huber",
            f_scale=HUBER_C,
            x_scale="jac",
            xtol=1e-12,
            ftol=1e-12,
            gtol=1e-12,
            max_nfev=max_evaluations,
        )
        evaluations += int(fit.nfev)
        moved = np.max(np.abs(fit.x - x) / np.maximum(np.abs(fit.x), 1e-9))
        x = fit.x
        if moved < 1e-9:
            break
    res = problem.residuals(x)
    found = outliers(res, n, jacobian=problem.jacobian(x))
    return FitResult(x, float(res @ res), evaluations, "", found, info={"outliers": len(found)})


def trimmed(problem: Problem, x0: np.ndarray, rounds: int = 10) -> FitResult:
    """Least squares on the poses the outlier test keeps, until the set settles.

    Each round fits the current inliers from the last solution, then judges
    every fitting pose against the inliers' robust scale.

    Returns
    -------
    FitResult
        ``cost``: sum of squared residuals over every fitting pose;
        ``outliers``: the poses left out of the last round.
    """
    n = len(problem)
    x = np.asarray(x0, dtype=float)
    out = np.array([], dtype=int)
    evaluations = 0
    for _ in range(rounds):
        keep = np.setdiff1d(np.arange(n), out)
        inliers = problem.subset(keep)
        fitted = refine.refine(inliers, x)
        x, evaluations = fitted.x, evaluations + fitted.evaluations
        res = problem.residuals(x)
        new = outliers(res, n, reference=inliers.residuals(x))
        if np.array_equal(new, out):
            break
        out = new
    res = problem.residuals(x)
    return FitResult(x, float(res @ res), evaluations, "", out, info={"outliers": len(out)})
