"""Alarms of a robot's history: pure functions of its records, no database.

Three kinds (docs/history.md says what each means and what to do):

- ``moved``: two consecutive calibrations differ in what belongs to the arm
  by more than their uncertainties (with their correlations) explain, and
  these parameters explain the difference (a crash, a re-mastered joint; the
  tool and the base only where they may be compared: :mod:`.compare`);
- ``limit`` / ``trend``: a series (held-out error, ISO 9283 AP or RP) is
  above its limit, or its straight-line trend
  over the last points reaches the limit within the horizon;
- ``check``: a check's verdict was ``drifted`` or ``recalibrate``.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime, timedelta

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
        When the record that raised it was measured (naive UTC).
    kind : {'moved', 'limit', 'trend', 'check', 'circle'}
    subject : str
        A parameter name, or a series (``held-out error``, ``AP``, ``RP``),
        or a check's verdict.
    message : str
        One sentence with the figures and their units.
    records : tuple of str
        The records it compares or judges (``calibration 3``, ``check 7``).
    figure, threshold : float or None
        The figure judged and the threshold it crossed, in ``unit``:
        ``moved``: the pair's chi-square and its quantile at the alarm
        probability; ``limit``: the value and the limit (mm); ``trend``: the
        value the trend line reaches at the horizon and the limit (mm);
        ``check``: the check's p-value and the alarm probability (below);
        ``circle``: the circle check's worst figure against its limit (mm).
    unit : str
    change, standard_error : float or None
        ``moved``: the parameter's change and its standard error (``change_unit``).
    change_unit : str
    """

    time: datetime
    kind: str
    subject: str
    message: str
    records: tuple[str, ...] = ()
    figure: float | None = None
    threshold: float | None = None
    unit: str = ""
    change: float | None = None
    standard_error: float | None = None
    change_unit: str = ""


@dataclass
class Limits:
    """Limits of the series (mm); ``None``: :data:`LIMIT_FACTOR` times the first value."""

    held_out_mm: float | None = None
    ap_mm: float | None = None
    rp_mm: float | None = None
    horizon: timedelta = HORIZON


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


def _scaled(name: str, value: float, sign: str = "") -> str:
    """A parameter value in display units: angles in mrad, lengths in mm (``sign='+'``: signed)."""
    from calibrator.report.data import unit_of

    if unit_of(name) == "rad":
        return f"{value * 1e3:{sign}.3g} mrad"
    return f"{value:{sign}.3g} mm"


def _time(record: dict) -> datetime:
    """When a record was measured: ``time`` (as the history reads it), else ``created``."""
    return record.get("time") or record["created"]


def _name(record: dict, kind: str) -> str:
    return f"{kind} {record['id']}" if "id" in record else kind


def moved(calibrations: Sequence[dict]) -> list[Alarm]:
    """What moved between consecutive calibrations beyond their uncertainties.

    Parameters
    ----------
    calibrations : sequence of dict
        Rows of the history (:meth:`History.calibrations`), in measured order:
        ``time`` (or ``created``), ``statistics`` (its ``arm`` and ``setup``)
        or, for rows recorded before them, ``parameters`` and ``uncertainties``.

    Returns
    -------
    list of Alarm
        One per parameter named by :func:`calibrator.history.compare.compare`.
    """
    from calibrator.history import compare
    from calibrator.report.data import unit_of

    found = []
    for before, after in zip(calibrations, calibrations[1:], strict=False):
        result = compare.compare(compare.state_of(before), compare.state_of(after))
        for change in result.changes:
            unit = unit_of(change.name)
            z = abs(change.change) / change.standard_error if change.standard_error > 0 else 0.0
            found.append(
                Alarm(
                    _time(after),
                    "moved",
                    change.name,
                    f"{describe(change.name)} moved {_scaled(change.name, change.change, '+')} "
                    f"± {_scaled(change.name, change.standard_error)} since "
                    f"{_time(before):%Y-%m-%d %H:%M:%S} ({z:.1f} standard errors; the two "
                    f"calibrations differ by chi2 {result.statistic:.1f} on {result.dof}, "
                    f"alarm above {result.threshold:.1f})",
                    records=(_name(before, "calibration"), _name(after, "calibration")),
                    figure=result.statistic,
                    threshold=result.threshold,
                    unit="chi2",
                    change=change.change,
                    standard_error=change.standard_error,
                    change_unit=unit,
                )
            )
    return found


def not_compared(calibrations: Sequence[dict]) -> list[str]:
    """What the consecutive calibrations could not be compared on, and why (one line each)."""
    from calibrator.history import compare

    said: dict[str, list[str]] = {}
    pairs = list(zip(calibrations, calibrations[1:], strict=False))
    for before, after in pairs:
        result = compare.compare(compare.state_of(before), compare.state_of(after))
        pair = f"{_name(before, 'calibration')} and {_name(after, 'calibration')}"
        for why in result.not_compared:
            said.setdefault(why, []).append(pair)
    every = "every two consecutive calibrations"
    return [
        f"{why} ({every if len(where) == len(pairs) > 1 else ', '.join(where)})"
        for why, where in said.items()
    ]


def crossing(
    subject: str, times: Sequence[datetime], values: Sequence[float | None], limit: float | None,
    horizon: timedelta = HORIZON, records: Sequence[str] | None = None,
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
    records : sequence of str, optional
        The record of each point (``calibration 3``).

    Returns
    -------
    list of Alarm
        ``limit`` for each point above the limit; ``trend`` for each point
        below it where the least-squares line through it and the
        :data:`TREND_POINTS` - 1 points below the limit before it rises and
        reaches the limit within ``horizon`` of it (as the history looked on
        that day).
    """
    names = list(records) if records is not None else [subject] * len(times)
    points = [
        (t, float(v), n) for t, v, n in zip(times, values, names, strict=True) if v is not None
    ]
    if not points:
        return []
    if limit is None:
        limit = LIMIT_FACTOR * points[0][1]
    alarms = []
    below: list[tuple] = []  # the points under the limit so far: a point above has its alarm
    for t, v, name in points:
        if v > limit:
            said = f"{subject} {v:.3f} mm is above its limit {limit:.3f} mm"
            alarms.append(
                Alarm(t, "limit", subject, said, records=(name,), figure=v, threshold=limit,
                      unit="mm")
            )  # fmt: skip
            continue
        below.append((t, v, name))
        if len(below) < TREND_POINTS:
            continue
        recent = below[-TREND_POINTS:]
        trend = _trend(recent, limit, horizon)
        if trend is not None:
            slope, reach, at_horizon = trend
            alarms.append(
                Alarm(
                    t, "trend", subject,
                    f"{subject} rises {slope * 30:.3f} mm a month over the last {TREND_POINTS} "
                    f"points and reaches its limit {limit:.3f} mm in about {max(reach, 0):.0f} "
                    f"days",
                    records=tuple(p[2] for p in recent),
                    figure=at_horizon, threshold=limit, unit="mm",
                )
            )  # fmt: skip
    return alarms


def _trend(
    recent: Sequence[tuple], limit: float, horizon: timedelta
) -> tuple[float, float, float] | None:
    """The line through ``recent`` points: (slope mm/day, days to the limit, value at the
    horizon mm) when it rises and reaches ``limit`` within ``horizon`` of the newest; else None."""
    t0 = recent[0][0]
    days = [(p[0] - t0).total_seconds() / 86400 for p in recent]
    ys = [p[1] for p in recent]
    mean_d, mean_y = sum(days) / len(days), sum(ys) / len(ys)
    spread = sum((d - mean_d) ** 2 for d in days)
    if spread == 0:
        return None
    slope = sum((d - mean_d) * (y - mean_y) for d, y in zip(days, ys, strict=True)) / spread
    if slope <= 0:
        return None
    now_fit = mean_y + slope * (days[-1] - mean_d)
    reach = (limit - now_fit) / slope  # days from the newest point
    ahead = horizon.total_seconds() / 86400
    if reach > ahead:
        return None
    return slope, reach, now_fit + slope * ahead


def check_verdicts(checks: Sequence[dict]) -> list[Alarm]:
    """Checks whose verdict is not ``ok``, with their explanation."""
    alarms = []
    for c in checks:
        if c["verdict"] == "ok":
            continue
        why = "; ".join(explanations(c)) or "no explanation recorded"
        doc = c.get("document") or {}
        p = doc.get("p_value")
        alarms.append(
            Alarm(
                c["time"],
                "check",
                c["verdict"],
                f"{c['verdict']}: measured {c['measured_mm']:.3f} mm against "
                f"{c['predicted_mm']:.3f} mm predicted; {why}",
                records=(_name(c, "check"),),
                figure=float(p) if isinstance(p, int | float) else None,
                threshold=float(doc.get("alarm_p", 1e-3)),
                unit="p (below)",
            )
        )
    return alarms


#: A circle check's figures with limits, as its alarm names them.
_CIRCLE_NAMES = {
    "radius_error_mm": "radius error",
    "out_of_roundness_mm": "out-of-roundness",
    "reversal_mm": "largest reversal mark",
}


def circle_verdicts(circles: Sequence[dict]) -> list[Alarm]:
    """Circle checks (``check --circle``) flagged: each figure beyond its limit, in mm.

    The alarm's figure and threshold are those of the figure furthest
    beyond its limit (as a share of the limit).
    """
    alarms = []
    for c in circles:
        if c["verdict"] == "ok":
            continue
        limits = ((c.get("document") or {}).get("circle") or {}).get("limits_mm") or {}
        beyond = [
            (abs(c[key]) / limits[key], key)
            for key in _CIRCLE_NAMES
            if isinstance(limits.get(key), int | float) and limits[key] > 0
            and abs(c[key]) > limits[key]
        ]  # fmt: skip
        parts = [
            f"{_CIRCLE_NAMES[key]} {c[key]:.3f} mm beyond its limit {limits[key]:g} mm"
            for _, key in sorted(beyond, reverse=True)
        ]
        worst = max(beyond)[1] if beyond else None
        alarms.append(
            Alarm(
                c["time"],
                "circle",
                c["verdict"],
                f"{c['verdict']}: " + ("; ".join(parts) or "no figure recorded beyond its limit"),
                records=(_name(c, "circle check"),),
                figure=None if worst is None else float(abs(c[worst])),
                threshold=None if worst is None else float(limits[worst]),
                unit="mm",
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
    circles: Sequence[dict] = (),
) -> list[Alarm]:
    """Every alarm of a robot's history, oldest first.

    Parameters
    ----------
    calibrations, verifications, checks : sequence of dict
        Rows as :class:`calibrator.history.History` reads them, oldest first.
    limits : Limits, optional
    circles : sequence of dict
        Circle checks (``History.circle_checks``), oldest first.
    """
    limits = limits or Limits()
    found = moved(calibrations)
    found += crossing(
        "held-out error",
        [_time(c) for c in calibrations],
        [c["held_out_rms_mm"] for c in calibrations],
        limits.held_out_mm,
        limits.horizon,
        [_name(c, "calibration") for c in calibrations],
    )
    # Compensated and nominal tests are different series: only the compensated
    # ones say how the calibration holds.
    tests = [v for v in verifications if v["compensated"]] or list(verifications)
    for subject, key, limit in (("AP", "ap_mm", limits.ap_mm), ("RP", "rp_mm", limits.rp_mm)):
        found += crossing(
            subject, [v["measured_at"] for v in tests], [v[key] for v in tests], limit,
            limits.horizon, [_name(v, "iso9283") for v in tests],
        )  # fmt: skip
    # A check judges its own error (its verdict): its figures raise no second alarm.
    found += check_verdicts(checks)
    found += circle_verdicts(circles)
    return sorted(found, key=lambda a: (a.time, a.kind, a.subject))


#: Columns of ``history alarms --csv`` (and keys of ``--json``), in order.
ALARM_COLUMNS = (
    "time",
    "kind",
    "subject",
    "records",
    "figure",
    "threshold",
    "unit",
    "change",
    "standard_error",
    "change_unit",
    "message",
)


def as_rows(found: Sequence[Alarm], robot: str | None = None) -> list[dict]:
    """Alarms as plain rows (:data:`ALARM_COLUMNS`, and ``robot`` first when given).

    ``time`` is ISO 8601 UTC to the second (or finer, as recorded);
    ``records`` the records compared, space-separated pairs joined by ``;``.
    """
    rows = []
    for a in found:
        row: dict = {"robot": robot} if robot is not None else {}
        row.update(
            time=a.time.isoformat() + "Z",
            kind=a.kind,
            subject=a.subject,
            records="; ".join(a.records),
            figure=a.figure,
            threshold=a.threshold,
            unit=a.unit,
            change=a.change,
            standard_error=a.standard_error,
            change_unit=a.change_unit,
            message=a.message,
        )
        rows.append(row)
    return rows


def csv_text(rows: Sequence[dict]) -> str:
    """Rows of :func:`as_rows` as CSV (empty cells for absent figures)."""
    import csv
    import io

    out = io.StringIO()
    columns = list(rows[0]) if rows else ["robot", *ALARM_COLUMNS]
    writer = csv.DictWriter(out, columns, lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: "" if v is None else v for k, v in row.items()})
    return out.getvalue()
