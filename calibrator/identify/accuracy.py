"""Accuracy statistics in the form of the IPSO paper's Table 3, and their text table."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from calibrator.model import measurement

if TYPE_CHECKING:
    from calibrator.model.measurement import Observations
    from calibrator.model.parameters import ParameterSpace

_AXES = ("x", "y", "z")


def error_stats(space: ParameterSpace, x: ArrayLike, obs: Observations) -> dict:
    """Position and orientation error statistics of one parameter set.

    Parameters
    ----------
    space : calibrator.model.parameters.ParameterSpace
    x : array_like, shape (space.size,)
    obs : calibrator.model.measurement.Observations

    Returns
    -------
    dict
        ``{"n": N, "position_mm": {"mean", "std", "max"}}`` of the distance
        between model and measured points, and with orientation data
        ``"orientation_deg": {"x"|"y"|"z": {"mean", "std", "max"}}`` of the
        absolute components of the rotation error about the tracker axes.
        Empty observations give ``{"n": 0}``.
    """
    if len(obs) == 0:
        return {"n": 0}
    position, orientation = measurement.errors(space, x, obs)
    out = {"n": len(obs), "position_mm": _summary(np.linalg.norm(position, axis=1))}
    if orientation is not None:
        deg = np.degrees(np.abs(orientation))
        out["orientation_deg"] = {a: _summary(deg[:, i]) for i, a in enumerate(_AXES)}
    return out


def before_after(space: ParameterSpace, x: np.ndarray, obs: Observations) -> dict:
    """``{"before": ..., "after": ...}``: :func:`error_stats` at the first guess and at ``x``."""
    return {
        "before": error_stats(space, np.zeros(space.size), obs),
        "after": error_stats(space, x, obs),
    }


def _summary(values):
    # Sample standard deviation, as in the IPSO paper's tables.
    std = float(np.std(values, ddof=1)) if len(values) > 1 else 0.0
    return {"mean": float(np.mean(values)), "std": std, "max": float(np.max(values))}


def format_table(stats: dict) -> str:
    """Before/after table like the IPSO paper's Table 3.

    Parameters
    ----------
    stats : dict
        ``{"fit": {"before": ..., "after": ...}, "validation": {...}}`` with
        entries from :func:`error_stats`.

    Returns
    -------
    str
    """
    lines = [f"{'':28s}{'mean':>10s}{'std':>10s}{'max':>10s}"]
    for part, title in (("fit", "fitted"), ("validation", "held-out")):
        before, after = stats[part]["before"], stats[part]["after"]
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
