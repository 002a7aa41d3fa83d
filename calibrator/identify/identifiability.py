"""What this session's poses can identify, judged in millimetres against the noise.

A parameter is kept when the session's own poses pin it down: its standard
error, predicted from the Jacobian at the first guess and an assumed
measurement noise, must be at most :data:`SE_THRESHOLD` of its plausible
size (:func:`calibrator.model.parameters.plausible_range`). Each column is thus
judged by its effect in mm over its plausible range against the noise,
not by its direction alone, so a parameter whose effect is tiny (``theta6``
with a tool point almost on the flange axis) is not mistaken for an
independent one.

The warnings below flag a session that fits but may not predict: too few
measured values per free parameter, near-duplicate poses, a high condition
number.
"""

from __future__ import annotations

from collections.abc import Sequence, Sized

import numpy as np
from numpy.typing import ArrayLike

from calibrator.errors import IdentifiabilityError
from calibrator.identify import uncertainty
from calibrator.model import parameters

#: Largest standard error, as a fraction of the plausible range, of a kept parameter.
SE_THRESHOLD = 0.3
#: Fewer measured values per free parameter than this gives a warning.
MIN_VALUES_PER_PARAMETER = 3.0
#: Joint vectors closer than this (rad, every joint) count as the same pose.
DUPLICATE_RAD = 1e-3
#: Condition number of the range-scaled Jacobian above which a warning is given.
MAX_CONDITION = 1e3


def scaled_information(jacobian: np.ndarray, names: Sequence[str], noise: float) -> np.ndarray:
    """Fisher information of the range-scaled parameters.

    Parameters
    ----------
    jacobian : ndarray, shape (M, D)
        Residual Jacobian (mm per mm or rad; orientation rows already carry
        ``sqrt(k)``).
    names : sequence of str, length D
    noise : float
        Standard deviation of one residual row (mm).

    Returns
    -------
    ndarray, shape (D, D)
        ``(J S)^T (J S) / noise^2`` with ``S = diag(plausible ranges)``: its
        inverse is the covariance of the deltas in units of their ranges.
    """
    scale = np.array([parameters.plausible_range(n) for n in names])
    js = jacobian * scale / noise
    return uncertainty.gram(js)


def relative_errors(info: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Standard errors in range units, and the correlation, from an information matrix.

    Returns
    -------
    se : ndarray, shape (D,)
        ``inf`` where the information is singular in that parameter.
    cov : ndarray, shape (D, D)
    """
    d = info.shape[0]
    diag = np.sqrt(np.maximum(np.diag(info), 1e-300))
    norm = info / np.outer(diag, diag)  # unit diagonal: the inverse is well scaled
    w, v = np.linalg.eigh(norm)
    tiny = w <= 1e-12 * max(w.max(), 1e-300)
    inv_w = np.where(tiny, 0.0, 1.0 / np.where(tiny, 1.0, w))
    cov = (v * inv_w) @ v.T / np.outer(diag, diag)
    se = np.sqrt(np.maximum(np.diag(cov), 0.0))
    # A parameter that takes part in a null direction is not determined at all.
    null = np.any(np.abs(v[:, tiny]) > 1e-6, axis=1) if tiny.any() else np.zeros(d, bool)
    se[null] = np.inf
    return se, cov


def select(
    names: Sequence[str], jacobian: np.ndarray, noise_mm: float, threshold: float = SE_THRESHOLD
) -> tuple[list[str], list[dict]]:
    """Drop, one at a time, the parameter these poses pin down worst.

    Parameters
    ----------
    names : sequence of str
        Candidates, in :data:`calibrator.model.parameters.ALL_NAMES` order.
    jacobian : ndarray, shape (M, len(names))
        At the first guess, on the fitting poses.
    noise_mm : float
        Assumed standard deviation of one residual row (mm).
    threshold : float
        :data:`SE_THRESHOLD`.

    Returns
    -------
    kept : list of str
    dropped : list of dict
        ``{"name", "reason"}``, the reason naming the standard error, the
        range and the kept parameter it is most confounded with.
    """
    kept = list(names)
    cols = list(range(len(names)))
    dropped = []
    while kept:
        info = scaled_information(jacobian[:, cols], kept, noise_mm)
        se, cov = relative_errors(info)
        worst = int(np.argmax(se))
        if se[worst] <= threshold:
            break
        name = kept[worst]
        rng = parameters.plausible_range(name)
        unit = parameters.unit(name)
        if se[worst] < 1e6:
            what = f"standard error {se[worst] * rng:.3g} {unit} with these poses"
        else:
            what = "not determined by these poses"
        partner = _most_correlated(info, worst, kept)
        reason = (
            f"{what} (at {noise_mm:g} mm noise; a kept parameter needs at most "
            f"{threshold:g} x its plausible {rng:g} {unit}){partner}"
        )
        dropped.append({"name": name, "reason": reason})
        del kept[worst], cols[worst]
    return kept, dropped


def _most_correlated(info, k, names):
    """`` , confounded with X`` from the information matrix's geometry, or ``""``."""
    if len(names) < 2:
        return ""
    diag = np.sqrt(np.maximum(np.diag(info), 1e-300))
    if diag[k] <= 1e-150:
        return ", no effect on these poses"
    cos = np.abs(info[k] / (diag * diag[k]))
    cos[k] = 0.0
    j = int(np.argmax(cos))
    return f", confounded with {names[j]} (cos {cos[j]:.3f})" if cos[j] > 0.5 else ""


def condition_number(info: np.ndarray) -> float:
    """Condition number of the range-scaled Jacobian (square root of the information's)."""
    w = np.linalg.eigvalsh(info)
    return float(np.sqrt(w.max() / w.min())) if w.min() > 0 else float("inf")


def duplicate_poses(q: ArrayLike, tol: float = DUPLICATE_RAD) -> np.ndarray:
    """Indices of poses whose joint vector repeats an earlier one within ``tol``.

    Poses are binned on a ``tol`` grid, so this is linear in the pose count
    (two poses just either side of a bin edge are not caught).

    Returns
    -------
    ndarray of int
    """
    keys = np.round(np.asarray(q) / tol).astype(np.int64)
    _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    return np.flatnonzero(first[inverse.ravel()] != np.arange(len(keys)))


def session_warnings(n_values: int, n_free: int, cond: float, duplicates: Sized) -> list[str]:
    """Warnings about the redundancy and spread of a session's poses (list of str)."""
    out = []
    if n_free and n_values / n_free < MIN_VALUES_PER_PARAMETER:
        out.append(
            f"only {n_values} measured values for {n_free} free parameters "
            f"({n_values / n_free:.1f} per parameter, fewer than "
            f"{MIN_VALUES_PER_PARAMETER:g}): the fit may not predict unseen poses; "
            "measure more poses"
        )
    if len(duplicates):
        out.append(
            f"{len(duplicates)} pose(s) repeat another pose's joint angles within "
            f"{DUPLICATE_RAD:g} rad; they add no information"
        )
    if cond > MAX_CONDITION:
        out.append(
            f"condition number {cond:.3g} of the scaled Jacobian is above "
            f"{MAX_CONDITION:g}: some parameter combinations are poorly determined "
            "(see the strongly correlated pairs)"
        )
    return out


def require_some(kept: Sequence[str]) -> None:
    """Refuse a session that can identify nothing."""
    if not kept:
        raise IdentifiabilityError(
            "these poses cannot identify any parameter: measure distinct, well-spread poses"
        )
