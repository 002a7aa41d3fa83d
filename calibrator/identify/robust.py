"""Fits that a few bad poses cannot drag: Huber, trimmed, and the outlier test.

A pose is an outlier when its whitened squared error, position (3 rows) and
with orientation data the weighted orientation (3 more), exceeds the 99.9 %
quantile of a chi-square with that many degrees of freedom. Each block is
whitened by a robust scale, ``1.4826 * median(|residual|)`` over its rows,
so the test is not blinded by the outliers it looks for.
"""

from __future__ import annotations

import numpy as np

from calibrator.identify import refine
from calibrator.identify.problem import FitResult, Problem

#: Chi-square 99.9 % quantiles for 3 and 6 degrees of freedom.
CHI2_999 = {3: 16.266, 6: 22.458}
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


def outliers(res: np.ndarray, n_poses: int, scale: np.ndarray) -> np.ndarray:
    """Poses whose whitened squared error exceeds the chi-square 99.9 % quantile.

    Parameters
    ----------
    res : ndarray, shape (3N,) or (6N,)
    n_poses : int
    scale : ndarray, same shape as ``res``
        From :func:`robust_scales` (of the inliers).

    Returns
    -------
    ndarray of int
    """
    z = (res / scale) ** 2
    blocks = len(res) // (3 * n_poses)
    per_pose = z.reshape(blocks, n_poses, 3).sum(axis=(0, 2))
    return np.flatnonzero(per_pose > CHI2_999[3 * blocks])


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
    found = outliers(res, n, robust_scales(res, n))
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
        scale = robust_scales(inliers.residuals(x), len(keep))
        # The scale per row of the whole set: each block's value repeated.
        full_scale = np.empty(len(res))
        full_scale[: 3 * n] = scale[0]
        full_scale[3 * n :] = scale[-1]
        new = outliers(res, n, full_scale)
        if np.array_equal(new, out):
            break
        out = new
    res = problem.residuals(x)
    return FitResult(x, float(res @ res), evaluations, "", out, info={"outliers": len(out)})
