"""The calibration as the check's prediction: where each probe point should be, and how surely.

The calibrated arm predicts the probe point of read-back joints ``q``; the
parameters' covariance of the calibration (its standard errors and
correlations) propagates to the predicted points through the Jacobian, and
the calibration's residual noise (per axis) stands for everything else a
held-out pose shows: the tracker's noise and what the model does not hold.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from calibrator.model import joint_terms, kinematics, measurement, parameters

if TYPE_CHECKING:
    from calibrator.calibration import Calibration


@dataclass(frozen=True)
class Calibrated:
    """A calibration linearised at its solution.

    Attributes
    ----------
    space : calibrator.model.parameters.ParameterSpace
        Free parameters of the calibration, nominal values at the calibrated
        arm (deltas ``x = 0`` are the calibration).
    cov : ndarray, shape (P, P)
        Covariance of the free parameters (mm, rad), zeros where the
        calibration records no uncertainty.
    sigma_mm : float
        Residual noise per axis of the calibration's fit, mm.
    terms : calibrator.model.joint_terms.JointTerms
    noise_dof : int or None
        Residual degrees of freedom ``sigma_mm`` was estimated from (the fitted
        poses' position rows less the free parameters); None when not recorded.
    """

    space: parameters.ParameterSpace
    cov: np.ndarray
    sigma_mm: float
    terms: joint_terms.JointTerms
    noise_dof: int | None = None

    @classmethod
    def of(cls, cal: Calibration) -> Calibrated:
        """From a :class:`calibrator.calibration.Calibration`."""
        free = tuple(n for n in cal.free if n in parameters.ALL_NAMES)
        space = parameters.ParameterSpace(cal.mdh, cal.base2tracker, cal.flange2tool, free)
        unc = cal.fit.uncertainty
        se = unc.get("standard_errors", {})
        corr = unc.get("correlation", {})
        cov = np.zeros((space.size, space.size))
        if se and corr.get("names"):
            where = {n: i for i, n in enumerate(corr["names"])}
            matrix = np.asarray(corr["matrix"], float)
            idx = [where.get(n) for n in space.free]
            for a, ia in enumerate(idx):
                for b, ib in enumerate(idx):
                    if ia is not None and ib is not None:
                        cov[a, b] = matrix[ia, ib] * se[space.free[a]] * se[space.free[b]]
        # An older or hand-written file may lack any of these: nothing recorded.
        residual = unc.get("residual_sigma")
        sigma = float(residual.get("position_mm") or 0.0) if residual else 0.0
        fit = cal.fit.stats.get("fit")
        fitted = fit.get("after", {}).get("n") if fit else None
        dof = 3 * int(fitted) - len(cal.free) if fitted else None
        return cls(space, cov, sigma, cal.joint_terms, dof if dof and dof > 0 else None)

    def angles(self, q: ArrayLike) -> np.ndarray:
        """The angles the calibrated chain turns through for read-back ``q`` (N, 6), rad."""
        q = kinematics.check_joints(q)
        if not self.terms.used:
            return q
        from calibrator.robots import masses

        torque = joint_terms.torque_function(
            self.terms, self.space.nominal_mdh, masses.for_terms(self.terms)
        )
        return joint_terms.effective(q, self.terms.vector(), None if torque is None else torque(q))

    def points(self, q: ArrayLike) -> np.ndarray:
        """Predicted probe points (N, 3), tracker frame, mm."""
        return measurement.predict(self.space, np.zeros(self.space.size), self.angles(q))[:, :3, 3]

    def jacobian(self, q: ArrayLike, names: tuple) -> np.ndarray:
        """Derivative of the predicted points (N, 3, len(names)) by the named parameters."""
        q_eff = self.angles(q)
        obs = measurement.Observations(q_eff, np.zeros((len(q_eff), 3)))
        jac = measurement.jacobian(self.space, np.zeros(self.space.size), obs, names=names)
        return jac.reshape(len(q_eff), 3, len(names))

    def covariance(self, q: ArrayLike) -> np.ndarray:
        """Covariance of a held-out error at ``q`` (3N, 3N), mm^2: parameters plus noise.

        The parameter part is common to all the poses (one calibration), so
        it couples them; the noise part is independent per axis and pose.
        """
        jac = self.jacobian(q, self.space.free).reshape(-1, self.space.size)
        return jac @ self.cov @ jac.T + self.sigma_mm**2 * np.eye(len(jac))
