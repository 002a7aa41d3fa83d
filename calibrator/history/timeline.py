"""A robot's records as one table over time (what ``history ROBOT`` prints and ``--csv`` writes)."""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass, field
from datetime import datetime
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from calibrator.history.store import History

#: Columns of the table, in order.
COLUMNS = (
    "time",
    "record",
    "id",
    "held_out_mm",
    "measured_mm",
    "predicted_mm",
    "ap_mm",
    "rp_mm",
    "at_p_mm",
    "rt_p_mm",
    "radius_error_mm",
    "out_of_roundness_mm",
    "reversal_mm",
    "verdict",
    "file",
)


@dataclass
class Timeline:
    """Everything the history holds of one robot, each list oldest first."""

    robot: dict
    calibrations: list = field(default_factory=list)
    sessions: list = field(default_factory=list)
    verifications: list = field(default_factory=list)
    checks: list = field(default_factory=list)
    trackers: list = field(default_factory=list)
    path_verifications: list = field(default_factory=list)
    circle_checks: list = field(default_factory=list)


def load(store: History, robot: str) -> Timeline:
    """A robot's records from a :class:`calibrator.history.History`."""
    calibrations = store.calibrations(robot)  # refuses an unknown robot first
    about = next(r for r in store.robots() if r["name"] == robot)
    sessions = store.sessions(robot)
    verifications = store.verifications(robot)
    paths = store.path_verifications(robot)
    circles = store.circle_checks(robot)
    used = {r["tracker"] for r in [*sessions, *verifications, *paths, *circles]}
    return Timeline(
        robot=about,
        calibrations=calibrations,
        sessions=sessions,
        verifications=verifications,
        checks=store.checks(robot),
        trackers=[t for t in store.trackers() if t["name"] in used],
        path_verifications=paths,
        circle_checks=circles,
    )


def table(data: Timeline) -> list[dict]:
    """One row per record (``COLUMNS``), oldest first; figures in mm, absent ones ``None``."""
    rows = []
    for s in data.sessions:
        rows.append(_row(s["measured_at"], "session", s["id"], file=s["file"]))
    for c in data.calibrations:
        rows.append(
            _row(
                c.get("time") or c["created"],
                "calibration",
                c["id"],
                held_out_mm=c["held_out_rms_mm"],
                predicted_mm=c["predicted_mm"],
                file=c["file"],
            )
        )
    for v in data.verifications:
        kind = "iso9283 compensated" if v["compensated"] else "iso9283 nominal"
        rows.append(
            _row(
                v["measured_at"], kind, v["id"], ap_mm=v["ap_mm"], rp_mm=v["rp_mm"], file=v["file"]
            )
        )
    for c in data.checks:
        rows.append(
            _row(
                c["time"],
                "check",
                c["id"],
                measured_mm=c["measured_mm"],
                predicted_mm=c["predicted_mm"],
                verdict=c["verdict"],
            )
        )
    for p in data.path_verifications:
        kind = f"path {p['shape']} " + ("compensated" if p["compensated"] else "nominal")
        rows.append(
            _row(
                p["measured_at"],
                kind,
                p["id"],
                at_p_mm=p["at_p_mm"],
                rt_p_mm=p["rt_p_mm"],
                file=p["file"],
            )
        )
    for c in data.circle_checks:
        rows.append(
            _row(
                c["time"],
                "circle check",
                c["id"],
                radius_error_mm=c["radius_error_mm"],
                out_of_roundness_mm=c["out_of_roundness_mm"],
                reversal_mm=c["reversal_mm"],
                verdict=c["verdict"],
            )
        )
    # At one time a session comes before what was made of it.
    rank = {"session": 0, "calibration": 1}
    return sorted(rows, key=lambda r: (r["time"], rank.get(r["record"], 2), r["record"], r["id"]))


def _row(time: datetime, record: str, number: int, **values: object) -> dict:
    row = dict.fromkeys(COLUMNS)
    row.update(time=time, record=record, id=number, **values)
    return row


def _cell(value: object, width: int = 0) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return f"{value:.4f}"
    if hasattr(value, "isoformat"):
        return value.isoformat(sep=" ", timespec="seconds")
    return str(value)


#: Figures a path test or circle check shows after its verdict in the text table: label, key.
_MORE = (
    ("AT_P", "at_p_mm"),
    ("RT_P", "rt_p_mm"),
    ("radius error", "radius_error_mm"),
    ("out-of-roundness", "out_of_roundness_mm"),
    ("reversal", "reversal_mm"),
)


def format_table(rows: list[dict]) -> str:
    """The table as text (mm, UTC times): a calibration's held-out error, a check's measured.

    A path test's AT_P and RT_P and a circle check's radius error,
    out-of-roundness and largest reversal mark follow the verdict column.
    """
    head = f"{'time (UTC)':19s}  {'record':20s} {'id':>5s} {'held-out':>9s} {'measured':>9s} "
    head += f"{'predicted':>9s} {'AP':>8s} {'RP':>8s}  verdict"
    lines = [head + "   (mm)"]
    for r in rows:
        more = "  ".join(f"{label} {_cell(r[key])}" for label, key in _MORE if r[key] is not None)
        line = (
            f"{_cell(r['time']):19s}  {r['record']:20s} {r['id']:5d} {_cell(r['held_out_mm']):>9s} "
            f"{_cell(r['measured_mm']):>9s} {_cell(r['predicted_mm']):>9s} "
            f"{_cell(r['ap_mm']):>8s} {_cell(r['rp_mm']):>8s}  {r['verdict'] or '':8s}  {more}"
        )
        lines.append(line.rstrip())
    return "\n".join(lines)


def csv_text(rows: list[dict]) -> str:
    """The table as CSV (``COLUMNS``; times ISO 8601 UTC; numbers as stored, mm)."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(COLUMNS)
    for r in rows:
        writer.writerow(
            [
                r[c].isoformat() if hasattr(r[c], "isoformat") else ("" if r[c] is None else r[c])
                for c in COLUMNS
            ]
        )
    return out.getvalue()
