"""Least-squares refinement of the identified deltas."""

import numpy as np

from calibrator.identify.problem import FitResult, Problem


def refine(problem: Problem, x0: np.ndarray, max_evaluations: int = 200) -> FitResult:
    """Minimise the sum of squared residuals from ``x0`` (Levenberg-Marquardt).

    Parameters
    ----------
    problem : calibrator.identify.problem.Problem
        Fitting poses, free set and orientation weight.
    x0 : array_like, shape (space.size,)
        Starting deltas (the swarm's best, or zeros).
    max_evaluations : int

    Returns
    -------
    FitResult
        ``cost`` is the sum of squared residuals (the seed's objective f).
    """
    # Imported here, not at module level: scipy.optimize costs about half a second of
    # start-up, which a run that never reaches this fit (pso, plan, report) must not pay.
    from scipy.optimize import least_squares

    result = least_squares(
        problem.residuals,
        np.asarray(x0, dtype=float),
        jac=problem.jacobian,
        method="lm",
        # Columns mix mm and rad and frames metres away: scale by the Jacobian.
        x_scale="jac",
        xtol=1e-14,
        ftol=1e-14,
        gtol=1e-14,
        max_nfev=max_evaluations,
    )
    return FitResult(result.x, float(2 * result.cost), int(result.nfev), str(result.message))
