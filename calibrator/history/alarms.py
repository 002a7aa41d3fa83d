"""Alarms of a robot's history: pure functions of its records, no database.

Three kinds (docs/history.md says what each means and what to do):

- ``moved``: a parameter moved beyond ``k`` (3) combined standard errors
  between two consecutive calibrations — more than their noise explains
  (a crash, a re-mastered joint, a changed tool);
- ``limit`` / ``trend``: a series (held-out error, ISO 9283 AP or RP) is
  above its limit, or its straight-line trend
  over the last points reaches the limit within the horizon;
- ``check``: a check's verdict was ``drifted`` or ``recalibrate``.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime, timedelta

#: Standard errors a parameter must move by between calibrations to raise an alarm.
K_SIGMA = 3.0
#: Limits are this times a series' first value, unless given.
LIMIT_FACTOR = 2.0
#: A trend alarm looks this far ahead.
HORIZON = timedelta(days=90)
#: Points of a series a trend is fitted on (the newest ones); fewer: no trend.
TREND_POINTS = 4


@dataclass(frozen=True)
class Alarm:
    """One alarm.

    Attributes
    ----------
    time : datetime
        When the record that raised it was made (naive UTC).
    kind : {'moved', 'limit', 'trend', 'check'}
    subject : str
        A parameter name, or a series (``held-out error``, ``AP``, ``RP``,
        ``check error``).
    message : str
        One sentence with the figures and their units.
    """

    time: datetime
    kind: str
    subject: str
    message: str


@dataclass
class Limits:
    """Limits of the series (mm); ``None``: :data:`LIMIT_FACTOR` times the first value."""

    held_out_mm: float | None = None
    ap_mm: float | None = None
    rp_mm: float | None = None
    horizon: timedelta = HORIZON
    k_sigma: float = K_SIGMA


def describe(name: str) -> str:
    """A parameter in words: ``theta2`` -> ``joint 2 zero (theta2)``."""
    match = re.fullmatch(r"(a|alpha|theta|d|beta)([1-6])", name)
    if match is None:
        return name
    what = {
        "a": "link length a",
        "alpha": "link twist alpha",
        "theta": "zero",
        "d": "link offset d",
        "beta": "twist beta",
    }[match[1]]
    return f"joint {match[2]} {what} ({name})"


def _scaled(name: str, value: float) -> str:
    """A parameter value in display units: angles in mrad, lengths in mm."""
    from calibrator.report.data import unit_of

    if unit_of(name) == "rad":
        return f"{value * 1e3:.3g} mrad"
    return f"{value:.3g} mm"


def moved(calibrations: Sequence[dict], k_sigma: float = K_SIGMA) -> list[Alarm]:
    """Parameters that moved beyond ``k_sigma`` standard errors between consecutive calibrations.

    Parameters
    ----------
    calibrations : sequence of dict
        Oldest first, each with ``created`` (datetime), ``parameters``
        (``{name: delta}``, mm or rad) and ``uncertainties`` (``{name:
        standard error}``, same units).
    k_sigma : float

    Returns
    -------
    list of Alarm
        One per parameter and pair; a parameter without a standard error in
        either calibration is not judged.
    """
    alarms = []
    for before, after in zip(calibrations, calibrations[1:], strict=False):
        for name, value in after["parameters"].items():
            if name not in before["parameters"]:
                continue
            se_a = before["uncertainties"].get(name)
            se_b = after["uncertainties"].get(name)
            if se_a is None or se_b is None:
                continue
            sigma = math.hypot(se_a, se_b)
            change = value - before["parameters"][name]
            if sigma > 0 and abs(change) > k_sigma * sigma:
                alarms.append(
                    Alarm(
                        after["created"],
                        "moved",
                        name,
                        f"{describe(name)} moved {_scaled(name, change)} "
                        f"± {_scaled(name, sigma)} since {before['created']:%Y-%m-%d} "
                        f"({abs(change) / sigma:.1f} standard errors)",
                    )
                )
    return alarms


def crossing(
    subject: str, times: Sequence[datetime], values: Sequence[float], limit: float | None,
    horizon: timedelta = HORIZON,
) -> list[Alarm]:  # fmt: skip
    """A series above its limit, or whose trend reaches it within ``horizon``.

    Parameters
    ----------
    subject : str
        The series' name (its values are in mm).
    times : sequence of datetime
        Oldest first.
    values : sequence of float
        mm; ``None`` values are skipped.
    limit : float or None
        mm; ``None``: :data:`LIMIT_FACTOR` times the first value.

    Returns
    -------
    list of Alarm
        ``limit`` for each point above the limit; else at most one ``trend``
        for the newest point, when the least-squares line through the last
        :data:`TREND_POINTS` points rises and reaches the limit within
        ``horizon`` of it.
    """
    points = [(t, float(v)) for t, v in zip(times, values, strict=True) if v is not None]
    if not points:
        return []
    if limit is None:
        limit = LIMIT_FACTOR * points[0][1]
    alarms = [
        Alarm(t, "limit", subject, f"{subject} {v:.3f} mm is above its limit {limit:.3f} mm")
        for t, v in points
        if v > limit
    ]
    recent = points[-TREND_POINTS:]
    if alarms and alarms[-1].time == points[-1][0] or len(recent) < TREND_POINTS:
        return alarms
    t0 = recent[0][0]
    days = [(t - t0).total_seconds() / 86400 for t, _ in recent]
    ys = [v for _, v in recent]
    mean_d, mean_y = sum(days) / len(days), sum(ys) / len(ys)
    spread = sum((d - mean_d) ** 2 for d in days)
    if spread == 0:
        return alarms
    slope = sum((d - mean_d) * (y - mean_y) for d, y in zip(days, ys, strict=True)) / spread
    if slope <= 0:
        return alarms
    now_fit = mean_y + slope * (days[-1] - mean_d)
    reach = (limit - now_fit) / slope  # days from the newest point
    if reach <= horizon.total_seconds() / 86400:
        alarms.append(
            Alarm(
                recent[-1][0],
                "trend",
                subject,
                f"{subject} rises {slope * 30:.3f} mm a month over the last {len(recent)} "
                f"points and reaches its limit {limit:.3f} mm in about {max(reach, 0):.0f} days",
            )
        )
    return alarms


def check_verdicts(checks: Sequence[dict]) -> list[Alarm]:
    """Checks whose verdict is not ``ok``, with their explanation."""
    alarms = []
    for c in checks:
        if c["verdict"] == "ok":
            continue
        why = "; ".join(explanations(c)) or "no explanation recorded"
        alarms.append(
            Alarm(
                c["time"],
                "check",
                c["verdict"],
                f"{c['verdict']}: measured {c['measured_mm']:.3f} mm against "
                f"{c['predicted_mm']:.3f} mm predicted; {why}",
            )
        )
    return alarms


def explanations(check: dict) -> list[str]:
    """A check's explanation as sentences.

    ``calibrator check`` writes them as ``explanation_text`` beside the
    structured ``explanation``; a document without them gives each item's
    ``text`` (or the item itself).
    """
    texts = (check.get("document") or {}).get("explanation_text")
    if isinstance(texts, list) and all(isinstance(s, str) for s in texts):
        return list(texts)
    return [explanation_text(e) for e in check["explanation"]]


def explanation_text(item: object) -> str:
    """One item of a check's explanation as text (an object's ``text`` or ``message``)."""
    if isinstance(item, dict):
        return str(item.get("text") or item.get("message") or item)
    return str(item)


def alarms(
    calibrations: Sequence[dict],
    verifications: Sequence[dict] = (),
    checks: Sequence[dict] = (),
    limits: Limits | None = None,
) -> list[Alarm]:
    """Every alarm of a robot's history, oldest first.

    Parameters
    ----------
    calibrations, verifications, checks : sequence of dict
        Rows as :class:`calibrator.history.History` reads them, oldest first.
    limits : Limits, optional
    """
    limits = limits or Limits()
    found = moved(calibrations, limits.k_sigma)
    found += crossing(
        "held-out error",
        [c["created"] for c in calibrations],
        [c["held_out_rms_mm"] for c in calibrations],
        limits.held_out_mm,
        limits.horizon,
    )
    # Compensated and nominal tests are different series: only the compensated
    # ones say how the calibration holds.
    tests = [v for v in verifications if v["compensated"]] or list(verifications)
    for subject, key, limit in (("AP", "ap_mm", limits.ap_mm), ("RP", "rp_mm", limits.rp_mm)):
        found += crossing(
            subject, [v["measured_at"] for v in tests], [v[key] for v in tests], limit,
            limits.horizon,
        )  # fmt: skip
    # A check judges its own error (its verdict): its figures raise no second alarm.
    found += check_verdicts(checks)
    return sorted(found, key=lambda a: (a.time, a.kind, a.subject))
