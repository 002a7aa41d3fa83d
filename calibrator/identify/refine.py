"""Least-squares refinement of the identified deltas."""

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from calibrator import measurement


@dataclass(frozen=True)
class RefineResult:
    """Outcome of :func:`refine`.

    Attributes
    ----------
    x : ndarray, shape (D,)
        Refined deltas.
    cost : float
        Sum of squared residuals (the seed's objective f).
    evaluations : int
        Residual evaluations used.
    message : str
        The solver's reason for stopping.
    """

    x: np.ndarray
    cost: float
    evaluations: int
    message: str


def refine(space, obs, x0, k=0.0, max_evaluations=200):
    """Minimise the sum of squared residuals from ``x0`` (Levenberg-Marquardt).

    Parameters
    ----------
    space : calibrator.parameters.ParameterSpace
    obs : calibrator.measurement.Observations
        Fitting poses.
    x0 : array_like, shape (space.size,)
        Starting deltas (the swarm's best, or zeros).
    k : float
        Orientation weight (mm^2/rad^2).
    max_evaluations : int

    Returns
    -------
    RefineResult
    """
    result = least_squares(
        lambda x: measurement.residuals(space, x, obs, k),
        np.asarray(x0, dtype=float),
        jac=lambda x: measurement.jacobian(space, x, obs, k),
        method="lm",
        # Columns mix mm and rad and frames metres away: scale by the Jacobian.
        x_scale="jac",
        xtol=1e-14,
        ftol=1e-14,
        gtol=1e-14,
        max_nfev=max_evaluations,
    )
    return RefineResult(result.x, float(2 * result.cost), int(result.nfev), str(result.message))
