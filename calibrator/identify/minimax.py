"""Minimise the worst pose's error: the swarm's result refined in epigraph form.

    minimise t  subject to  e_j(x) <= t  for every fitting pose j,

with ``e_j = |dp_j|^2 + k |delta_j|^2`` (squared, so smooth), solved by SLSQP
on deltas scaled to their plausible ranges. Only the poses near the current
worst take part as constraints; the solution is checked against every pose,
and any pose above ``t`` joins the set for another round, so the answer
judges all poses without a dense constraint Jacobian over thousands.
"""

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from calibrator import measurement, parameters

#: Up to this many poses, every pose is a constraint from the start.
ALL_POSES = 500
#: Beyond that, poses whose squared error is above this fraction of the worst
#: one start as constraints.
ACTIVE_FRACTION = 0.25


@dataclass(frozen=True)
class MinimaxResult:
    """Outcome of :func:`refine_minimax`.

    Attributes
    ----------
    x : ndarray, shape (D,)
    worst : float
        Largest per-pose error ``sqrt(e_j)`` over all fitting poses (mm).
    iterations : int
    message : str
    """

    x: np.ndarray
    worst: float
    iterations: int
    message: str


def pose_errors(space, x, obs, k):
    """``e_j``, shape (N,): squared per-pose error (mm^2)."""
    res = measurement.residuals(space, x, obs, k)
    return (res**2).reshape(-1, len(obs), 3).sum(axis=(0, 2))


def _pose_error_jacobian(space, x, obs, k):
    res = measurement.residuals(space, x, obs, k)
    jac = measurement.jacobian(space, x, obs, k)
    n = len(obs)
    blocks = len(res) // (3 * n)
    r = res.reshape(blocks, n, 3)
    j = jac.reshape(blocks, n, 3, -1)
    return (r**2).sum(axis=(0, 2)), 2.0 * np.einsum("bni,bnid->nd", r, j)


def refine_minimax(space, obs, x0, k, rounds=5, max_iterations=300):
    """SLSQP on the epigraph form from ``x0``.

    Returns
    -------
    MinimaxResult
        The best point seen (never worse than ``x0`` over all poses).
    """
    scale = np.array([parameters.plausible_range(n) for n in space.free])
    best = np.asarray(x0, dtype=float)
    e_best = pose_errors(space, best, obs, k)
    if len(obs) <= ALL_POSES:
        active = np.arange(len(obs))
    else:
        active = np.flatnonzero(e_best >= ACTIVE_FRACTION * e_best.max())
    x, iterations, message = best, 0, ""
    for _ in range(rounds):
        sub = obs.subset(active)
        t0 = float(pose_errors(space, x, sub, k).max())

        def cons(v, sub=sub, t0=t0):
            return v[-1] * t0 - pose_errors(space, v[:-1] * scale, sub, k)

        def cons_jac(v, sub=sub, t0=t0):
            _, grad = _pose_error_jacobian(space, v[:-1] * scale, sub, k)
            return np.column_stack([-grad * scale, np.full(len(grad), t0)])

        out = minimize(
            lambda v: v[-1],
            np.append(x / scale, 1.0),
            jac=lambda v: np.eye(len(v))[-1],
            constraints=[{"type": "ineq", "fun": cons, "jac": cons_jac}],
            method="SLSQP",
            options={"maxiter": max_iterations, "ftol": 1e-10},
        )
        iterations += int(out.nit)
        message = str(out.message)
        x = out.x[:-1] * scale
        e = pose_errors(space, x, obs, k)
        if e.max() < e_best.max():
            best, e_best = x, e
        missing = np.setdiff1d(np.flatnonzero(e > e[active].max() * (1 + 1e-6)), active)
        if not len(missing):
            break
        active = np.union1d(active, missing)
    return MinimaxResult(best, float(np.sqrt(e_best.max())), iterations, message)
