"""Helpers of the history's tests: check documents and a dump of a whole history."""

from __future__ import annotations

from datetime import datetime, timedelta

CAL_SHA = "ab" * 32


def check_doc(robot="arm-1", day=0, verdict="ok", measured=0.05, explanation=()):
    """A ``calibrator check`` document (the fields ``record_check`` takes)."""
    return {
        "robot": robot,
        "time": (datetime(2026, 1, 1) + timedelta(days=day)).isoformat() + "Z",
        "calibration_sha256": CAL_SHA,
        "verdict": verdict,
        "measured_mm": measured,
        "predicted_mm": 0.05,
        "pose_errors_mm": [measured] * 8,
        "explanation": list(explanation),
    }


def dump(history) -> dict:
    """Every row of every table of a history (ids and all), in id order."""
    from sqlalchemy import select

    from calibrator.history import schema

    out = {}
    with history.engine.connect() as conn:
        for table in schema.metadata.sorted_tables:
            rows = conn.execute(select(table).order_by(table.c.id)).all()
            out[table.name] = [dict(r._mapping) for r in rows]
    return out
