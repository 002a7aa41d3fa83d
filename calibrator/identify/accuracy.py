"""Accuracy statistics in the form of the IPSO paper's Table 3, and their text table."""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal

import numpy as np
from numpy.typing import ArrayLike

from calibrator.fit_records import AxesSummary, BeforeAfter, ErrorStats, FitStats, Summary
from calibrator.model import measurement

if TYPE_CHECKING:
    from calibrator.model.measurement import Observations
    from calibrator.model.parameters import ParameterSpace

_AXES: tuple[Literal["x"], Literal["y"], Literal["z"]] = ("x", "y", "z")


def error_stats(space: ParameterSpace, x: ArrayLike, obs: Observations) -> ErrorStats:
    """Position and orientation error statistics of one parameter set.

    Parameters
    ----------
    space : calibrator.model.parameters.ParameterSpace
    x : array_like, shape (space.size,)
    obs : calibrator.model.measurement.Observations

    Returns
    -------
    ErrorStats
        ``{"n": N, "position_mm": {"mean", "std", "max"}}`` of the distance
        between model and measured points, and with orientation data
        ``"orientation_deg": {"x"|"y"|"z": {"mean", "std", "max"}}`` of the
        absolute components of the rotation error about the tracker axes.
        Empty observations give ``{"n": 0}``.
    """
    if len(obs) == 0:
        return {"n": 0}
    position, orientation = measurement.errors(space, x, obs)
    out: ErrorStats = {"n": len(obs), "position_mm": _summary(np.linalg.norm(position, axis=1))}
    if orientation is not None:
        deg = np.degrees(np.abs(orientation))
        axes = AxesSummary(x=_summary(deg[:, 0]), y=_summary(deg[:, 1]), z=_summary(deg[:, 2]))
        out["orientation_deg"] = axes
    return out


def before_after(space: ParameterSpace, x: np.ndarray, obs: Observations) -> BeforeAfter:
    """``{"before": ..., "after": ...}``: :func:`error_stats` at the first guess and at ``x``."""
    return {
        "before": error_stats(space, np.zeros(space.size), obs),
        "after": error_stats(space, x, obs),
    }


def fit_stats(
    space: ParameterSpace, x: np.ndarray, fit: Observations, validation: Observations
) -> FitStats:
    """calibration.json's ``stats``: :func:`before_after` on the fitted and the held-out poses."""
    return FitStats(fit=before_after(space, x, fit), validation=before_after(space, x, validation))


def _summary(values: np.ndarray) -> Summary:
    # Sample standard deviation, as in the IPSO paper's tables.
    std = float(np.std(values, ddof=1)) if len(values) > 1 else 0.0
    return {"mean": float(np.mean(values)), "std": std, "max": float(np.max(values))}


def format_table(stats: FitStats) -> str:
    """Before/after table like the IPSO paper's Table 3.

    Parameters
    ----------
    stats : FitStats
        ``{"fit": {"before": ..., "after": ...}, "validation": {...}}`` with
        entries from :func:`error_stats`.

    Returns
    -------
    str
    """
    lines = [f"{'':28s}{'mean':>10s}{'std':>10s}{'max':>10s}"]
    for part, title in (stats["fit"], "fitted"), (stats["validation"], "held-out"):
        before, after = part["before"], part["after"]
        if before["n"] == 0:
            lines.append(f"{title} poses: none")
            continue
        lines.append(f"{title} poses ({before['n']})")
        lines += _rows("position (mm)", before["position_mm"], after["position_mm"])
        for axis in _AXES if "orientation_deg" in before else ():
            lines += _rows(
                f"orientation {axis.upper()} (deg)",
                before["orientation_deg"][axis],
                after["orientation_deg"][axis],
            )
    return "\n".join(lines)


def _rows(label, before, after):
    def row(when, s):
        return f"  {label + ' ' + when:26s}{s['mean']:10.4f}{s['std']:10.4f}{s['max']:10.4f}"

    return [row("before", before), row("after", after)]
