"""Least-squares refinement of the identified deltas."""

import numpy as np

from calibrator.identify import levmar
from calibrator.identify.problem import FitResult, Problem


def refine(problem: Problem, x0: np.ndarray, max_evaluations: int = 200) -> FitResult:
    """Minimise the sum of squared residuals from ``x0`` (Levenberg-Marquardt).

    The fit is :func:`calibrator.identify.levmar.levenberg_marquardt`, the
    method of ``scipy.optimize.least_squares(method="lm", x_scale="jac")``
    without its import, which costs about half a second of start-up that
    the default ``identify`` would pay for this one call.

    Parameters
    ----------
    problem : calibrator.identify.problem.Problem
        Fitting poses, free set and orientation weight.
    x0 : array_like, shape (space.size,)
        Starting deltas (the swarm's best, or zeros).
    max_evaluations : int
        Most residual evaluations (the one at ``x0`` included).

    Returns
    -------
    FitResult
        ``cost`` is the sum of squared residuals (the IPSO paper's objective f);
        ``evaluations`` the residual evaluations made.
    """
    found = levmar.levenberg_marquardt(
        problem.residuals,
        np.asarray(x0, dtype=float),
        problem.jacobian,
        max_evaluations=max_evaluations,
        # Tight: the swarm only brings the fit near; least squares decides the answer.
        # The columns mix mm and rad and frames metres away: the fit scales them by
        # the Jacobian's column norms.
        ftol=1e-14,
        xtol=1e-14,
        gtol=1e-14,
    )
    return FitResult(found.x, found.cost, found.evaluations, found.message)
