"""What the history stores of each file: one row a record, read and checked before writing.

Pure functions of a file or document (no database): each returns the row
(a dict of column values) and what names its robot and tracker. Anything
wrong is a :class:`HistoryError` in one line naming the file and the field;
the store writes nothing then.
"""

from __future__ import annotations

import hashlib
import json
import math
import re
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from calibrator.errors import CalibrationError
from calibrator.history import compare

if TYPE_CHECKING:
    import pyarrow as pa


class HistoryError(CalibrationError):
    """A record the history refuses, or a history it cannot open."""


#: ``calibrator check``'s verdicts, best first.
VERDICTS = ("ok", "drifted", "recalibrate")
_HEX64 = re.compile(r"^[0-9a-f]{64}$")


@dataclass(frozen=True)
class Record:
    """A row to write and who it belongs to (derive with ``dataclasses.replace()``).

    Attributes
    ----------
    row : dict
        Column values of its table (robot and tracker ids left out).
    robot : str or None
        The robot's name as the file gives it (``None``: the file names none).
    tracker : str or None
        The tracker's ``vendor:model:serial`` (``None``: not recorded).
    model : str or None
        The arm's model name, for a robot seen the first time.
    session : str or None
        A calibration's session file, to find its robot when the history
        has not seen the session.
    """

    row: dict
    robot: str | None = None
    tracker: str | None = None
    model: str | None = None
    session: str | None = None
    extra: dict = field(default_factory=dict)


@contextmanager
def _as_history_error() -> Iterator[None]:
    """A file the domain refuses is a record the history refuses (same one line)."""
    try:
        yield
    except HistoryError:
        raise
    except CalibrationError as exc:
        raise HistoryError(str(exc)) from None


def sha256_bytes(data: bytes) -> str:
    """SHA-256 of bytes (hex)."""
    return hashlib.sha256(data).hexdigest()


def document_sha256(doc: object) -> str:
    """SHA-256 of a JSON document in canonical form (sorted keys, no spaces)."""
    text = json.dumps(doc, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return sha256_bytes(text.encode())


def utc(text: object, where: str) -> datetime:
    """An ISO 8601 time as a naive UTC datetime (a time without zone is taken as UTC)."""
    if not isinstance(text, str):
        raise HistoryError(f"{where}: time must be an ISO 8601 string, got {text!r:.40}")
    try:
        when = datetime.fromisoformat(text)
    except ValueError:
        raise HistoryError(f"{where}: {text!r:.40} is not an ISO 8601 time") from None
    if when.tzinfo is not None:
        when = when.astimezone(UTC).replace(tzinfo=None)
    return when


def file_time(path: Path) -> datetime:
    """A file's modification time, naive UTC (for files that record no time)."""
    return datetime.fromtimestamp(path.stat().st_mtime, UTC).replace(tzinfo=None)


def _number(doc: dict, key: str, where: str) -> float:
    value = doc.get(key)
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise HistoryError(f"{where}: '{key}' must be a finite number, got {value!r:.40}")
    return float(value)


def _get(doc: object, *keys: str) -> object:
    """``doc[keys[0]][keys[1]]...``, None where a level is missing or not an object."""
    for key in keys:
        if not isinstance(doc, dict):
            return None
        doc = doc.get(key)
    return doc


def calibration(path: Path) -> Record:
    """The record of a calibration.json (checked by :func:`calibrator.calibration.load`).

    The row holds the free parameters' deltas (mm, rad), their standard
    errors, the fit statistics (mm, deg), the provenance, and the held-out,
    predicted and fitted mean position errors (mm).
    """
    from calibrator import calibration as calibrations

    path = Path(path)
    with _as_history_error():
        cal = calibrations.load(path)
    where = str(path)
    stats = cal.fit.stats
    unc = cal.fit.uncertainty
    created = cal.provenance.created
    row = {
        "sha256": calibrations.digest(path),
        "file": str(path),
        "created": utc(created, f"{where}: 'created'") if created else file_time(path),
        "model": cal.model,
        "session_sha256": cal.provenance.session_sha256,
        "held_out_rms_mm": _get(stats, "validation", "after", "position_mm", "mean"),
        "predicted_mm": _get(unc, "predicted_validation_mm", "error_mean"),
        "fit_rms_mm": _get(stats, "fit", "after", "position_mm", "mean"),
        "parameters": {k: float(v) for k, v in cal.deltas.items()},
        "uncertainties": {
            k: float(v) for k, v in (unc.get("standard_errors") or {}).items() if k in cal.deltas
        },
        "statistics": {
            "stats": stats,
            "residual_sigma": unc.get("residual_sigma"),
            "predicted_validation_mm": unc.get("predicted_validation_mm"),
            "warnings": cal.fit.warnings,
            # What the alarms compare: identified values and their covariance.
            "arm": compare.arm_block(cal),
        },
        "provenance": {
            **cal.provenance.to_json(),
            "session": cal.session,
            "free_parameters": list(cal.free),
            "dropped_parameters": cal.dropped,
        },
    }
    for key in ("held_out_rms_mm", "predicted_mm", "fit_rms_mm"):
        value = row[key]
        row[key] = float(value) if isinstance(value, int | float) else None
    return Record(row, model=cal.model, session=cal.session)


def verification(path: Path) -> Record:
    """The record of verify's JSON (docs/verify.md): the largest AP and RP over the test poses."""
    from calibrator.inputs import jsonfile

    path = Path(path)
    where = str(path)
    if not path.is_file():
        raise HistoryError(f"verify file not found: {path}")
    data = path.read_bytes()
    with _as_history_error():
        doc = jsonfile.load_json(data, where)
    if not isinstance(doc, dict) or doc.get("format") != "calibrator.verify":
        raise HistoryError(f"{where} is not a calibrator verify file")
    if doc.get("test") == "path":
        return path_verification(path, data, doc)
    poses = doc.get("poses")
    if not isinstance(poses, list) or not poses or not all(isinstance(p, dict) for p in poses):
        raise HistoryError(f"{where}: 'poses' must be a list of test poses")
    ap = max(_number(p, "AP_mm", where) for p in poses)
    rp = max(_number(p, "RP_mm", where) for p in poses)
    return _verify_record(
        path, data, doc, {"compensated": bool(doc.get("compensated")), "ap_mm": ap, "rp_mm": rp}
    )


def _verify_record(path: Path, data: bytes, doc: dict, figures: dict) -> Record:
    """A verify document's record: digest, file, time, ``figures`` and the document itself.

    The robot, tracker and model are the ones the document names.
    """
    robot, tracker = doc.get("robot"), doc.get("tracker")
    row = {
        "sha256": sha256_bytes(data),
        "file": str(path),
        # verify.json records no time: the file's is when it was written.
        "measured_at": utc(doc["time"], str(path)) if "time" in doc else file_time(path),
        **figures,
        "document": doc,
    }
    return Record(
        row,
        robot=robot if isinstance(robot, str) and robot else None,
        tracker=tracker if isinstance(tracker, str) and tracker else None,
        model=doc.get("model") if isinstance(doc.get("model"), str) else None,
    )


#: A path test's figures: the document's key under ``path`` -> the row's column.
PATH_FIGURES = {
    "speed_mm_s": "speed_mm_s",
    "AT_P_mm": "at_p_mm",
    "RT_P_mm": "rt_p_mm",
    "AV_pct": "av_pct",
    "RV_pct": "rv_pct",
    "FV_mm_s": "fv_mm_s",
}


#: A path test's orientation figures (a 6-DoF probe's; None from a reflector): key -> column.
PATH_ORIENTATION = {
    "ATa_deg": "ata_deg",
    "ATb_deg": "atb_deg",
    "ATc_deg": "atc_deg",
    "RTa_deg": "rta_deg",
    "RTb_deg": "rtb_deg",
    "RTc_deg": "rtc_deg",
}


def _optional_number(doc: dict, key: str, where: str) -> float | None:
    """A figure a document may leave out or give as null (None), else a finite number."""
    return None if doc.get(key) is None else _number(doc, key, where)


def is_path_record(record: Record) -> bool:
    """Whether a :func:`verification` record is a path test's (table ``path_verifications``)."""
    return "at_p_mm" in record.row


def path_verification(path: Path, data: bytes, doc: dict) -> Record:
    """The record of ``verify --path``'s JSON: its shape, speed and clause 7 figures.

    The orientation figures (:data:`PATH_ORIENTATION`, deg) are None when the
    document has none (a reflector's test, or one written before they were).
    """
    where = str(path)
    section = doc.get("path")
    if not isinstance(section, dict):
        raise HistoryError(f"{where}: a path test needs its 'path' section")
    shape = section.get("shape")
    if not isinstance(shape, str) or not shape:
        raise HistoryError(f"{where}: path.shape must name the path")
    figures: dict[str, float | None] = {
        col: _number(section, key, f"{where}: path") for key, col in PATH_FIGURES.items()
    }
    figures.update(
        {
            col: _optional_number(section, key, f"{where}: path")
            for key, col in PATH_ORIENTATION.items()
        }
    )
    return _verify_record(
        path,
        data,
        doc,
        {"compensated": bool(section.get("compensated")), "shape": shape, **figures},
    )


def session(path: Path) -> Record:
    """The record of a session file: digest, time, poses, conditions, robot and tracker.

    The robot is the one the footer's ``measured`` names (``measure`` writes
    it); a simulated session's is named like the simulated robot
    (``sim:MODEL:seed=N``). Conditions are the session's summary of its
    condition columns (``{column: {"min", "mean", "max"}, ...}``), or a
    footer's ``conditions`` object; ``{}`` when it has none.
    """
    import pyarrow.parquet as pq

    from calibrator import calibration as calibrations
    from calibrator import session as sessions

    path = Path(path)
    with _as_history_error():
        loaded = sessions.load(path)
    extra = loaded.meta.extra
    found = extra.get("measured")
    measured: dict = found if isinstance(found, dict) else {}
    robot = measured.get("robot")
    simulated = extra.get("simulated")
    if not robot and isinstance(simulated, dict) and loaded.meta.model:
        robot = f"sim:{loaded.meta.model}:seed={simulated.get('seed')}"
    measured_at = measured_time(loaded.table, extra, str(path)) or file_time(path).replace(
        microsecond=0
    )
    # The per-pose condition columns summed up (Session.conditions, where this
    # calibrator has it), else a ``conditions`` object in the footer.
    summed = getattr(loaded, "conditions", None)
    conditions = summed() if callable(summed) else extra.get("conditions")
    row = {
        "sha256": calibrations.digest(path),
        "file": str(path.resolve()),
        "measured_at": measured_at,
        "model": loaded.meta.model,
        "poses": pq.ParquetFile(path).metadata.num_rows,
        "conditions": conditions if isinstance(conditions, dict) else {},
        "setup": setup(extra, str(path)),
    }
    tracker = measured.get("tracker")
    return Record(
        row,
        robot=str(robot) if robot else None,
        tracker=str(tracker) if tracker else None,
        model=loaded.meta.model,
    )


def measured_time(table: pa.Table, extra: dict, where: str) -> datetime | None:
    """When a session was measured (naive UTC): its first pose's ``timestamp``.

    A session without timestamps (an imported or simulated file) may give
    its time in the footer's ``measured_at`` (ISO 8601); ``None`` when it
    gives neither.
    """
    first = _first_time(table)
    if first is not None:
        return first
    given = extra.get("measured_at")
    return None if given is None else utc(given, f"{where}: footer 'measured_at'")


def setup(extra: dict, where: str) -> dict:
    """What a session's footer declares of its set-up: ``tool_id``, ``tracker_pose``.

    ``tool_id`` (text) names the tool on the flange (the reflector and its
    nest): two calibrations compare their tool only when both name the same.
    ``tracker_pose`` (``{"world": NAME, "tracker2world": 4x4, mm}``) is where
    the tracker stood in a fixed world frame (e.g. measured on reference
    nests): two calibrations compare their base only when both give one in
    the same world. Either may be absent.
    """
    from calibrator.model import frames

    out: dict = {}
    tool = extra.get("tool_id")
    if tool is not None:
        if not isinstance(tool, str) or not tool.strip():
            raise HistoryError(f"{where}: footer 'tool_id' must be the tool's name (text)")
        out["tool_id"] = tool.strip()
    pose = extra.get("tracker_pose")
    if pose is not None:
        world = pose.get("world") if isinstance(pose, dict) else None
        if not isinstance(world, str) or not world.strip():
            raise HistoryError(
                f"{where}: footer 'tracker_pose' must be {{\"world\": NAME, "
                '"tracker2world": 4x4 matrix (mm)}'
            )
        try:
            matrix = np.asarray(pose.get("tracker2world"), dtype=float)
            if matrix.shape != (4, 4) or not np.all(np.isfinite(matrix)):
                raise ValueError("a 4x4 matrix of finite numbers")
            frames.check_transform(matrix, "tracker2world")
        except (TypeError, ValueError, CalibrationError) as exc:
            raise HistoryError(
                f"{where}: footer 'tracker_pose.tracker2world' must be a rigid 4x4 transform "
                f"(mm): {exc}"
            ) from None
        out["tracker_pose"] = {"world": world.strip(), "tracker2world": matrix.tolist()}
    return out


def _first_time(table: pa.Table) -> datetime | None:
    """The earliest ``timestamp`` of a session's rows (naive UTC), if it records them."""
    if "timestamp" not in table.column_names:
        return None
    stamps = []
    for value in table.column("timestamp").to_pylist():
        if isinstance(value, datetime):
            aware = value.tzinfo is not None
            stamps.append(value.astimezone(UTC).replace(tzinfo=None) if aware else value)
        elif isinstance(value, str):
            try:
                stamps.append(utc(value, "timestamp"))
            except HistoryError:
                continue
    return min(stamps) if stamps else None


#: Fields of a check document: name -> what it must be.
CHECK_FIELDS = {
    "robot": "the robot's name (text)",
    "time": "when it was measured (ISO 8601)",
    "calibration_sha256": "the SHA-256 of the calibration checked (64 hex digits)",
    "verdict": "one of " + ", ".join(VERDICTS),
    "measured_mm": "the measured error (mm, a finite number >= 0)",
    "predicted_mm": "the error the calibration predicts (mm, a finite number >= 0)",
    "pose_errors_mm": "the error at each pose (mm, a list of finite numbers)",
    "explanation": "what explains a change (a list, empty when none)",
}


def check(doc: object, where: str = "check") -> Record:
    """The record of a ``calibrator check`` document (fields: :data:`CHECK_FIELDS`).

    Extra keys (conditions, tracker, the poses, ...) are kept in the stored
    document. Its identity is the digest of the canonical JSON, so the same
    check recorded twice is one record.
    """
    if not isinstance(doc, dict):
        raise HistoryError(f"{where}: a check must be a JSON object")
    missing = [k for k in CHECK_FIELDS if k not in doc]
    if missing:
        raise HistoryError(
            f"{where}: missing {missing[0]!r}: {CHECK_FIELDS[missing[0]]}"
            + (f" (and {len(missing) - 1} more)" if len(missing) > 1 else "")
        )
    robot = doc["robot"]
    if not isinstance(robot, str) or not robot.strip():
        raise HistoryError(f"{where}: 'robot' must be {CHECK_FIELDS['robot']}")
    digest = doc["calibration_sha256"]
    if not isinstance(digest, str) or not _HEX64.match(digest):
        need = CHECK_FIELDS["calibration_sha256"]
        raise HistoryError(f"{where}: 'calibration_sha256' must be {need}")
    if doc["verdict"] not in VERDICTS:
        raise HistoryError(
            f"{where}: 'verdict' must be {CHECK_FIELDS['verdict']}, got {doc['verdict']!r:.40}"
        )
    measured = _number(doc, "measured_mm", where)
    predicted = _number(doc, "predicted_mm", where)
    if measured < 0 or predicted < 0:
        raise HistoryError(f"{where}: 'measured_mm' and 'predicted_mm' must be >= 0")
    errors = doc["pose_errors_mm"]
    if not isinstance(errors, list) or not all(
        isinstance(e, int | float) and not isinstance(e, bool) and math.isfinite(e) for e in errors
    ):
        raise HistoryError(f"{where}: 'pose_errors_mm' must be {CHECK_FIELDS['pose_errors_mm']}")
    if not isinstance(doc["explanation"], list):
        raise HistoryError(f"{where}: 'explanation' must be {CHECK_FIELDS['explanation']}")
    try:
        sha = document_sha256(doc)
    except (TypeError, ValueError) as exc:
        raise HistoryError(f"{where}: not plain JSON ({exc})") from None
    row = {
        "sha256": sha,
        # When the poses were measured, if the document says (a check of a
        # recorded session); else when it was made.
        "time": utc(doc.get("measured_at") or doc["time"], f"{where}: 'time'"),
        "calibration_sha256": digest,
        "verdict": doc["verdict"],
        "measured_mm": measured,
        "predicted_mm": predicted,
        "pose_errors_mm": [float(e) for e in errors],
        "explanation": doc["explanation"],
        "document": json.loads(json.dumps(doc)),
    }
    tracker = doc.get("tracker")
    return Record(row, robot=robot.strip(), tracker=tracker if isinstance(tracker, str) else None)


#: ``calibrator check --circle``'s document format (:mod:`calibrator.check.circle_procedure`).
CIRCLE_FORMAT = "calibrator-check-circle"
#: The circle test's verdicts.
CIRCLE_VERDICTS = ("ok", "flagged")
#: Figures of a circle test's ``circle`` section: key -> the row's column (mm, mm/s).
CIRCLE_FIGURES = {
    "speed_mm_s": "speed_mm_s",
    "radius_error_mm": "radius_error_mm",
    "out_of_roundness_mm": "out_of_roundness_mm",
    "reversal_mm": "reversal_mm",
    "centre_offset_norm_mm": "centre_offset_mm",
}


def circle_check(doc: object, where: str = "circle check") -> Record:
    """The record of a ``calibrator check --circle`` document.

    The row holds when it ran, the calibration it compensated with, the
    commanded radius and speed, the radius error, out-of-roundness, largest
    reversal mark, centre offset and direction gap (mm), the verdict, and the
    document itself. Its identity is the digest of the canonical JSON, so the
    same test recorded twice is one record.

    Raises
    ------
    HistoryError
        Not a circle test's document, or a field missing or malformed (named).
    """
    if not isinstance(doc, dict) or doc.get("format") != CIRCLE_FORMAT:
        raise HistoryError(f"{where} is not a calibrator check --circle file")
    robot = doc.get("robot")
    if not isinstance(robot, str) or not robot.strip():
        raise HistoryError(f"{where}: 'robot' must be the robot's name (text)")
    digest = doc.get("calibration_sha256")
    if not isinstance(digest, str) or not _HEX64.match(digest):
        need = CHECK_FIELDS["calibration_sha256"]
        raise HistoryError(f"{where}: 'calibration_sha256' must be {need}")
    section = doc.get("circle")
    if not isinstance(section, dict):
        raise HistoryError(f"{where}: a circle test needs its 'circle' section")
    verdict = section.get("verdict")
    if verdict not in CIRCLE_VERDICTS or doc.get("verdict") != verdict:
        raise HistoryError(
            f"{where}: 'verdict' must be one of {', '.join(CIRCLE_VERDICTS)} (the same as "
            f"circle.verdict), got {doc.get('verdict')!r:.40}"
        )
    inside = f"{where}: circle"
    figures = {col: _number(section, key, inside) for key, col in CIRCLE_FIGURES.items()}
    commanded = section.get("commanded")
    commanded = commanded if isinstance(commanded, dict) else {}
    radius = _number(commanded, "radius_mm", f"{inside}.commanded")
    try:
        sha = document_sha256(doc)
    except (TypeError, ValueError) as exc:
        raise HistoryError(f"{where}: not plain JSON ({exc})") from None
    row = {
        "sha256": sha,
        "time": utc(doc.get("time"), f"{where}: 'time'"),
        "calibration_sha256": digest,
        "compensated": bool(section.get("compensated")),
        "radius_mm": radius,
        **figures,
        "direction_gap_mm": _optional_number(section, "direction_gap_mm", inside),
        "verdict": verdict,
        "document": json.loads(json.dumps(doc)),
    }
    tracker, model = doc.get("tracker"), doc.get("model")
    return Record(
        row,
        robot=robot.strip(),
        tracker=tracker if isinstance(tracker, str) and tracker else None,
        model=model if isinstance(model, str) else None,
    )
