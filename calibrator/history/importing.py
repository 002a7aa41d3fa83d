"""``history import DIR``: the sessions, calibrations, verify, check and circle files in DIR."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from calibrator.errors import CalibrationError
from calibrator.history.records import HistoryError

if TYPE_CHECKING:
    from calibrator.history.store import History


def kind_of(path: Path) -> str | None:
    """``session``, ``calibration``, ``verification``, ``check``, ``circle`` or ``None``."""
    suffix = path.suffix.lower()
    if suffix == ".parquet":
        # verify and check write their poses beside their JSON: those are not sessions.
        beside = path.with_suffix(".json")
        poses_of = ("calibrator.verify", "calibrator.check")
        return None if beside.is_file() and _format(beside) in poses_of else "session"
    if suffix == ".json":
        return _KINDS.get(_format(path) or "")
    return None


#: The JSON files import records: format -> kind.
_KINDS = {
    "calibrator.calibration": "calibration",
    "calibrator.verify": "verification",
    "calibrator.check": "check",
    "calibrator-check-circle": "circle",
}


def _format(path: Path) -> str | None:
    """The ``format`` key of a JSON file (``None``: not JSON, or no such key)."""
    try:
        doc = json.loads(path.read_bytes())
    except (OSError, ValueError):
        return None
    except RecursionError:  # a file an import names and skips, not one that ends the import
        raise HistoryError(f"{path}: JSON nested too deeply to read") from None
    return doc.get("format") if isinstance(doc, dict) else None


def _document(path: Path) -> dict:
    """A check or circle file's document (checked by ``record_check``, ``record_circle_check``)."""
    from calibrator.inputs import jsonfile

    try:
        doc = jsonfile.load_json(path.read_bytes(), str(path))
    except CalibrationError as exc:
        raise HistoryError(str(exc)) from None
    return doc if isinstance(doc, dict) else {}


def import_folder(
    store: History,
    folder: Path,
    robot: str | None = None,
    on_skip: Callable[[Path, str], None] = lambda path, why: None,
) -> dict[str, int]:
    """Record every session, calibration, verify, check and circle file under ``folder``.

    Sessions go first so calibrations find their robot. Each file is its own
    transaction: a file refused (``on_skip(path, reason)``) leaves the others
    recorded.

    Returns
    -------
    dict
        ``{"session": n, "calibration": n, "verification": n, "check": n, "circle": n}``
        recorded or already there.
    """
    found: dict[str, list[Path]] = {
        "session": [],
        "calibration": [],
        "verification": [],
        "check": [],
        "circle": [],
    }
    for path in sorted(p for p in folder.rglob("*") if p.is_file()):
        try:
            kind = kind_of(path)
        except HistoryError as exc:
            on_skip(path, str(exc))
            continue
        if kind is not None:
            found[kind].append(path)
    record = {
        "session": store.record_session,
        "calibration": store.record_calibration,
        "verification": store.record_verification,
        "check": lambda path, robot: store.record_check(_document(path)),
        "circle": lambda path, robot: store.record_circle_check(_document(path)),
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
