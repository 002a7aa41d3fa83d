"""``history import DIR``: the sessions, calibrations and verify files under a folder."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

from calibrator.history.records import HistoryError


def kind_of(path: Path) -> str | None:
    """``session``, ``calibration``, ``verification`` or ``None`` (a file none of these)."""
    suffix = path.suffix.lower()
    if suffix == ".parquet":
        # verify writes its attained poses beside its JSON: those are not a session.
        beside = path.with_suffix(".json")
        return None if beside.is_file() and _format(beside) == "calibrator.verify" else "session"
    if suffix == ".json":
        return {"calibrator.calibration": "calibration", "calibrator.verify": "verification"}.get(
            _format(path) or ""
        )
    return None


def _format(path: Path) -> str | None:
    """The ``format`` key of a JSON file (``None``: not JSON, or no such key)."""
    try:
        doc = json.loads(path.read_bytes())
    except (OSError, ValueError):
        return None
    return doc.get("format") if isinstance(doc, dict) else None


def import_folder(
    store: Any,
    folder: Path,
    robot: str | None = None,
    on_skip: Callable[[Path, str], None] = lambda path, why: None,
) -> dict[str, int]:
    """Record every session, calibration and verify file under ``folder``.

    Sessions go first so calibrations find their robot. Each file is its own
    transaction: a file refused (``on_skip(path, reason)``) leaves the others
    recorded.

    Returns
    -------
    dict
        ``{"session": n, "calibration": n, "verification": n}`` recorded or already there.
    """
    found: dict[str, list[Path]] = {"session": [], "calibration": [], "verification": []}
    for path in sorted(p for p in folder.rglob("*") if p.is_file()):
        kind = kind_of(path)
        if kind is not None:
            found[kind].append(path)
    record = {
        "session": store.record_session,
        "calibration": store.record_calibration,
        "verification": store.record_verification,
    }
    counts = dict.fromkeys(found, 0)
    for kind, paths in found.items():
        for path in paths:
            try:
                record[kind](path, robot)
            except HistoryError as exc:
                on_skip(path, str(exc))
                continue
            counts[kind] += 1
    return counts
