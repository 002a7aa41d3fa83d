"""The check's verdict: is the measured error what the calibration predicts?

Under an unchanged arm, the errors ``e`` (measured minus predicted points,
3N values) are Gaussian with the covariance ``V`` of
:meth:`calibrator.check.model.Calibrated.covariance` (the calibration's
parameter uncertainty, common to all poses, plus its residual noise), widened
where this check's tracker spread is larger than that noise. Then
``T = e^T V^-1 e`` follows a chi-square law with 3N degrees of freedom, or,
since ``V`` scales with the calibration's residual noise, itself estimated
from ``nu`` residual degrees of freedom, ``T / 3N`` follows Fisher's F law
with ``(3N, nu)`` degrees of freedom (a calibration from few poses knows its
noise loosely, and the test widens accordingly):

- ``ok``: ``T`` is below its ``1 - ALARM_P`` quantile (a false alarm once in
  :data:`ALARM_P`\\ :sup:`-1` checks of an unchanged arm);
- ``drifted``: above it, and the measured mean error is within
  :data:`RECALIBRATE_RATIO` times the predicted one (or the user's tolerance):
  the arm changed measurably, the calibration still serves;
- ``recalibrate``: above it, and the measured mean error is beyond that.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from calibrator.identify.uncertainty import MEAN_OVER_RMS, sigma_bias

VERDICTS = ("ok", "drifted", "recalibrate")
#: Probability of an alarm on an unchanged arm (per check).
ALARM_P = 1e-3
#: Measured over predicted mean error beyond which a changed arm needs a new calibration.
RECALIBRATE_RATIO = 2.0


@dataclass(frozen=True)
class Verdict:
    """How the measured errors compare with the prediction.

    Attributes
    ----------
    verdict : {'ok', 'drifted', 'recalibrate'}
    measured_mm : float
        Mean distance between measured and predicted points, mm.
    predicted_mm : float
        Its expected value under an unchanged arm, mm.
    statistic : float
        ``e^T V^-1 e``.
    dof : int
        ``3N``.
    p_value : float
        Chance of a statistic at least this large on an unchanged arm.
    limit_mm : float
        Mean error beyond which a significant change asks for a recalibration, mm.
    """

    verdict: str
    measured_mm: float
    predicted_mm: float
    statistic: float
    dof: int
    p_value: float
    limit_mm: float

    def to_json(self) -> dict:
        return {
            "verdict": self.verdict,
            "measured_mm": self.measured_mm,
            "predicted_mm": self.predicted_mm,
            "chi2": self.statistic,
            "dof": self.dof,
            "p_value": self.p_value,
            "alarm_p": ALARM_P,
            "recalibrate_above_mm": self.limit_mm,
        }


def covariance(model_cov: np.ndarray, spread_mm: np.ndarray | None, sigma_mm: float) -> np.ndarray:
    """The errors' covariance (3N, 3N), mm^2, with this check's own tracker noise.

    Parameters
    ----------
    model_cov : ndarray, shape (3N, 3N)
        :meth:`~calibrator.check.model.Calibrated.covariance` at the poses.
    spread_mm : ndarray, shape (N, 3), optional
        Standard error of each averaged point per axis (spread over the root of
        the readings), mm: where it exceeds the calibration's noise the excess is added.
    sigma_mm : float
        The calibration's residual noise per axis, mm.
    """
    cov = np.array(model_cov, dtype=float)
    if spread_mm is not None:
        excess = np.maximum(np.asarray(spread_mm, float).ravel() ** 2 - sigma_mm**2, 0.0)
        cov[np.diag_indices_from(cov)] += excess
    return cov


def p_value(statistic: float, dof: int, noise_dof: int | None = None) -> float:
    """Chance of ``statistic`` or more from noise alone: chi-square, or F with ``noise_dof``."""
    if noise_dof is None:
        return float(stats.chi2.sf(statistic, dof))
    return float(stats.f.sf(statistic / dof, dof, noise_dof))


def judge(
    errors_mm: np.ndarray,
    cov: np.ndarray,
    tolerance_mm: float | None = None,
    noise_dof: int | None = None,
) -> Verdict:
    """The verdict on errors (N, 3) mm with covariance ``cov`` (3N, 3N) mm^2.

    ``tolerance_mm`` replaces ``RECALIBRATE_RATIO`` times the predicted mean
    error; ``noise_dof`` is the residual degrees of freedom the calibration's
    noise was estimated from (None: taken as exact).
    """
    e = np.asarray(errors_mm, float)
    n = len(e)
    statistic = float(e.ravel() @ np.linalg.solve(cov, e.ravel()))
    dof = 3 * n
    p = p_value(statistic, dof, noise_dof)
    per_pose = np.sqrt(np.einsum("nii->n", pose_blocks(cov, n)))
    # As identify's prediction: the root of a noise estimated from few rows is low by c4.
    predicted = float(MEAN_OVER_RMS * per_pose.mean() / sigma_bias(noise_dof))
    measured = float(np.linalg.norm(e, axis=1).mean())
    limit = RECALIBRATE_RATIO * predicted if tolerance_mm is None else float(tolerance_mm)
    if p >= ALARM_P:
        verdict = "ok"
    elif measured <= limit:
        verdict = "drifted"
    else:
        verdict = "recalibrate"
    return Verdict(verdict, measured, predicted, statistic, dof, p, limit)


def pose_blocks(cov: np.ndarray, n: int) -> np.ndarray:
    """The (N, 3, 3) diagonal blocks of a (3N, 3N) matrix."""
    idx = np.arange(n)[:, None] * 3 + np.arange(3)
    return cov[idx[:, :, None], idx[:, None, :]]
