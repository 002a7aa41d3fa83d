"""identify's result against least squares started from the truth, on the same fitting poses.

The acceptance figure of the external-robot tests: within 1.5x of what the
best fit of the same data reaches, in residual RMS and in the error of the
predicted reflector positions against the true arm.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from calibrator import calibration, session
from calibrator.identify import pipeline
from calibrator.identify.problem import Problem
from calibrator.identify.refine import refine
from calibrator.model import kinematics, parameters


def against_least_squares_from_truth(
    cwd: Path, truth: tuple, plan: np.ndarray, true_points: np.ndarray
) -> dict:
    """Figures of ``cwd/cal.json`` (identified from ``cwd/s.parquet``) against the truth.

    Parameters
    ----------
    truth : tuple
        ``(mdh (6, 5), flange2tool (4, 4), base2tracker (4, 4))`` of the true arm, mm and rad.
    plan : ndarray, shape (N, 6)
        Every plan pose (rad), measured or not.
    true_points : ndarray, shape (N, 3)
        The true reflector position at each, tracker frame, mm.

    Returns
    -------
    dict
        RMS and prediction error of identify and of the baseline (mm), and their ratios.
    """
    cal = calibration.load(cwd / "cal.json")
    obs = session.load(cwd / "s.parquet").observations
    space = parameters.ParameterSpace(cal.nominal_mdh, cal.base0, cal.tool0, cal.free)
    ran = cal.provenance.options  # the split the fit made
    assert ran is not None
    fit_idx, _ = pipeline.split(len(obs), ran.validation_fraction, ran.seed)
    problem = Problem.of(space, obs.subset(fit_idx), 0.0)
    found = space.pack(cal.mdh, cal.base2tracker, cal.flange2tool)
    mdh, tool, base2tracker = truth
    baseline = refine(problem, space.pack(mdh, base2tracker, tool))

    def rms(x):
        return float(np.sqrt(np.mean(problem.residuals(x) ** 2)))

    def prediction(x):  # over every plan pose, the never measured ones included
        mdh, base2tracker, tool = space.unpack(x)
        model = kinematics.forward(mdh, plan, tool, base2tracker)[:, :3, 3]
        return float(np.sqrt(np.mean(np.sum((model - true_points) ** 2, axis=1))))

    out = {
        "identify_rms_mm": rms(found),
        "baseline_rms_mm": rms(baseline.x),
        "identify_prediction_mm": prediction(found),
        "baseline_prediction_mm": prediction(baseline.x),
    }
    out["rms_ratio"] = out["identify_rms_mm"] / out["baseline_rms_mm"]
    out["prediction_ratio"] = out["identify_prediction_mm"] / out["baseline_prediction_mm"]
    return out
