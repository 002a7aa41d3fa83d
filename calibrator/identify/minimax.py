"""Minimise the worst pose's error: the swarm's result refined in epigraph form.

    minimise t  subject to  e_j(x) <= t  for every fitting pose j,

with ``e_j = |dp_j|^2 + k |delta_j|^2`` (squared, so smooth), solved by SLSQP
on deltas scaled to their plausible ranges. Only the poses near the current
worst take part as constraints; the solution is checked against every pose,
and any pose above ``t`` joins the set for another round, so the answer
judges all poses without a dense constraint Jacobian over thousands.
"""

import numpy as np

from calibrator.fit_records import StepInfo
from calibrator.identify.problem import FitResult, Problem
from calibrator.model import parameters

#: Up to this many poses, every pose is a constraint from the start.
ALL_POSES = 500
#: Beyond that, poses whose squared error is above this fraction of the worst
#: one start as constraints.
ACTIVE_FRACTION = 0.25


def _pose_error_jacobian(problem, x):
    res = problem.residuals(x)
    jac = problem.jacobian(x)
    n = len(problem)
    blocks = len(res) // (3 * n)
    r = res.reshape(blocks, n, 3)
    j = jac.reshape(blocks, n, 3, -1)
    return (r**2).sum(axis=(0, 2)), 2.0 * np.einsum("bni,bnid->nd", r, j)


def refine_minimax(
    problem: Problem, x0: np.ndarray, rounds: int = 5, max_iterations: int = 300
) -> FitResult:
    """SLSQP on the epigraph form from ``x0``.

    Returns
    -------
    FitResult
        The best point seen (never worse than ``x0`` over all poses);
        ``cost`` is the worst pose's squared error (mm^2), ``evaluations``
        the SLSQP iterations, ``info`` holds ``worst_mm`` and ``iterations``.
    """
    # Imported here, not at module level: scipy.optimize costs about half a second of
    # start-up, which a run that never reaches this fit (pso, plan, report) must not pay.
    from scipy.optimize import minimize

    scale = np.array([parameters.plausible_range(n) for n in problem.space.free])
    best = np.asarray(x0, dtype=float)
    e_best = problem.pose_errors(best)
    if len(problem) <= ALL_POSES:
        active = np.arange(len(problem))
    else:
        active = np.flatnonzero(e_best >= ACTIVE_FRACTION * e_best.max())
    x, iterations, message = best, 0, ""
    for _ in range(rounds):
        sub = problem.subset(active)
        t0 = float(sub.pose_errors(x).max())

        def cons(v, sub=sub, t0=t0):
            return v[-1] * t0 - sub.pose_errors(v[:-1] * scale)

        def cons_jac(v, sub=sub, t0=t0):
            _, grad = _pose_error_jacobian(sub, v[:-1] * scale)
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
        e = problem.pose_errors(x)
        if e.max() < e_best.max():
            best, e_best = x, e
        missing = np.setdiff1d(np.flatnonzero(e > e[active].max() * (1 + 1e-6)), active)
        if not len(missing):
            break
        active = np.union1d(active, missing)
    worst = float(np.sqrt(e_best.max()))
    info = StepInfo(worst_mm=worst, iterations=iterations)
    return FitResult(best, float(e_best.max()), iterations, message, info=info)
