"""The append-only journal beside a session being measured: crash safety and ``--resume``.

One JSON object per line. The first line is the header: which plan, robot and
tracker the run belongs to, and the session metadata. Every further line is
one finished pose (measured, or failed after its retries), written, flushed
and fsynced before the robot moves again, so a crash (even SIGKILL) loses at
most the pose in progress. A line cut short by a crash is dropped on resume.

A journal is input like any file: :func:`read` validates every line (its
CRC-32, the types and ranges of every field, the pose being a row of the
plan and its joints the plan's within :data:`JOINT_MATCH_RAD`) and refuses
the first bad one, naming its line number. The process that writes a
journal holds an exclusive lock on it, so a second ``measure --resume`` of
the same run is refused while the first one runs.

Floats go through JSON's shortest round-trip repr, so a row read back from the
journal is bit-for-bit the row that was measured.
"""

from __future__ import annotations

import fcntl
import json
import math
import os
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

import numpy as np
from numpy.typing import ArrayLike

from calibrator.errors import CalibrationError
from calibrator.inputs import jsonfile, messages
from calibrator.inputs.errors import StrictError
from calibrator.robots import JointConvention

FORMAT = "calibrator.journal"
#: 2 adds a CRC-32 to every line; version 1 journals (no CRC) are still read.
VERSION = 2
READABLE_VERSIONS = (1, 2)
#: Largest difference between a measured pose's joints (read back from the
#: arm after the readings) and its plan row, rad: a robot ends a move within
#: its tolerance (1e-3 rad for the UR adapter), a record copied from another
#: pose or hand-edited joints do not.
JOINT_MATCH_RAD = 0.01
#: Largest coordinate a reading may have, mm (no tracker reaches 1 km).
MAX_COORD_MM = 1e6
#: Key of each line's CRC-32 (of the line's JSON without it).
CRC_KEY = "crc32"
#: Header keys that must match for a resume: the run's identity.
IDENTITY_KEYS = ("plan_sha256", "robot", "tracker", "readings")
#: The header key saying the records' joints are the controller's angles (journals
#: written before it held the model's).
JOINTS_KEY = "joints"
_IDENTITY = JointConvention()


class JournalError(CalibrationError):
    """A journal is unreadable or belongs to another run."""


def journal_path(output: str | os.PathLike[str]) -> Path:
    """Where the journal of the session ``output`` lives: beside it, ``<name>.journal``."""
    output = Path(output)
    return output.with_name(output.name + ".journal")


@dataclass
class Resumed:
    """What a journal already holds.

    Attributes
    ----------
    header : dict
    records : dict
        Last record of every pose number that has one (``{pose: record}``).
    """

    header: dict
    records: dict


class Journal:
    """An open journal, appending one fsynced line per finished pose.

    Use :meth:`create` for a new run and :meth:`resume` to continue one.
    Records hold the model's joint angles; their lines hold the controller's
    (``convention``, the arm's), as the session does.
    """

    def __init__(
        self,
        path: Path,
        fh: IO[str],
        version: int = VERSION,
        convention: JointConvention = _IDENTITY,
    ) -> None:
        self.path = path
        self._fh = fh
        self.version = version
        self.convention = convention

    @classmethod
    def create(
        cls, path: str | os.PathLike[str], header: dict, convention: JointConvention = _IDENTITY
    ) -> Journal:
        """Start a journal, locked; never replaces an existing one (it may hold a run's poses)."""
        path = Path(path)
        try:
            fh = open(path, "x", encoding="utf-8")  # noqa: SIM115  closed by close()
        except FileExistsError:
            raise JournalError(
                f"{path} exists (an unfinished run): pass --resume to continue it, "
                "or remove it to start over"
            ) from None
        _lock(fh, path)
        journal = cls(path, fh, VERSION, convention)
        journal._write({"format": FORMAT, "version": VERSION, JOINTS_KEY: "controller", **header})
        _fsync_dir(path)
        return journal

    @classmethod
    def resume(
        cls,
        path: str | os.PathLike[str],
        header: dict,
        plan_rad: ArrayLike | None = None,
        convention: JointConvention = _IDENTITY,
    ) -> tuple[Journal, Resumed]:
        """Lock a journal, check every line and that it belongs to this run, reopen it to append.

        Parameters
        ----------
        path : str or Path
        header : dict
            This run's header (:data:`IDENTITY_KEYS` must match).
        plan_rad : array_like, shape (N, 6), optional
            This run's plan: every record's pose must be a row of it and its
            joints that row's (see :func:`read`).
        convention : calibrator.robots.JointConvention
            The arm's (see :func:`read`).

        Raises
        ------
        JournalError
            No journal, one another process is writing (a run in progress),
            not a journal, a bad line, or its plan, robot, tracker or reading
            count differ from ``header``.
        """
        path = Path(path)
        if not path.is_file():
            raise JournalError(f"no journal to resume: {path} not found")
        fh = open(path, "a", encoding="utf-8")  # noqa: SIM115  closed by close()
        try:
            _lock(fh, path)
            done = read(path, plan_rad=plan_rad, expect=header, convention=convention)
            _truncate_partial_line(path)
        except BaseException:
            fh.close()
            raise
        return cls(path, fh, done.header["version"], convention), done

    def append(self, record: dict) -> None:
        """Write one finished pose durably (flush and fsync) before returning.

        Raises
        ------
        ValueError
            A non-finite number in the record (refused, never written).
        """
        if "q_rad" in record:
            q = self.convention.to_controller(np.asarray(record["q_rad"], dtype=float))
            record = {**record, "q_rad": q.tolist()}
        self._write(record)

    def _write(self, obj: dict) -> None:
        self._fh.write(encode_line(obj, crc=self.version >= 2))
        self._fh.flush()
        os.fsync(self._fh.fileno())

    def close(self) -> None:
        if not self._fh.closed:
            self._fh.close()

    def __enter__(self) -> Journal:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def encode_line(obj: dict, *, crc: bool = True) -> str:
    """One journal line: the JSON of ``obj`` with its CRC-32 as the last key, and a newline.

    Raises
    ------
    ValueError
        NaN or an infinity anywhere in ``obj``.
    """
    text = json.dumps(obj, allow_nan=False)
    if not crc:
        return text + "\n"
    return text[:-1] + f', "{CRC_KEY}": {zlib.crc32(text.encode())}}}\n'


def read(
    path: str | os.PathLike[str],
    plan_rad: ArrayLike | None = None,
    expect: dict | None = None,
    convention: JointConvention = _IDENTITY,
) -> Resumed:
    """Read and validate a journal: its header and the last record of each pose.

    Parameters
    ----------
    path : str or Path
    plan_rad : array_like, shape (N, 6), optional
        The run's plan; with it every record's joints are checked against
        their plan row (within :data:`JOINT_MATCH_RAD`).
    expect : dict, optional
        This run's header: its :data:`IDENTITY_KEYS` must match the journal's
        (checked before any record).
    convention : calibrator.robots.JointConvention
        The arm's: a journal whose header says ``"joints": "controller"``
        holds the controller's angles, returned as the model's; one written
        before that key held the model's.

    Raises
    ------
    JournalError
        Missing file, a first line that is not a journal header, or the first
        line that fails a check, named by its number.
    """
    path = Path(path)
    if not path.is_file():
        raise JournalError(f"no journal to resume: {path} not found")
    with open(path, "rb") as fh:
        lines = fh.read().split(b"\n")
    header = _parse(lines[0], crc=None)
    if not isinstance(header, dict) or header.get("format") != FORMAT:
        raise JournalError(f"{path} is not a calibrator journal")
    version = header.get("version")
    if type(version) is not int or version not in READABLE_VERSIONS:
        raise JournalError(
            f"{path}: journal version {messages.shown(version)} is not supported (this program "
            f"reads versions {', '.join(map(str, READABLE_VERSIONS))}); finish it with the "
            "program that wrote it, or remove it to start over"
        )
    crc = version >= 2
    if crc:
        header = _parse(lines[0], crc=True)
        if header is None:
            raise JournalError(f"{path}: line 1 (the header) is damaged: its CRC does not match")
    for key in IDENTITY_KEYS if expect is not None else ():
        theirs, ours = header.get(key), expect.get(key)  # type: ignore[union-attr]
        if theirs != ours:
            raise JournalError(
                f"{path} belongs to another run: its {key} is {theirs!r}, this run's is {ours!r}"
            )
    plan = None if plan_rad is None else np.asarray(plan_rad, dtype=float)
    stated = header.get(JOINTS_KEY, "model")
    if stated not in ("controller", "model"):
        raise JournalError(f"{path}: {JOINTS_KEY} must be 'controller' or 'model', got {stated!r}")
    to_model = convention if stated == "controller" else _IDENTITY
    check = _RecordCheck(header, plan, to_model)
    records = {}
    # The last element is "" after a complete file, or a line a crash cut short.
    for number, line in enumerate(lines[1:-1], start=2):
        record = _parse(line, crc=crc)
        if record is None:
            raise JournalError(f"{path}: line {number} is damaged (not JSON, or its CRC differs)")
        problem = check(record)
        if problem:
            raise JournalError(f"{path}: line {number} is damaged: {problem}")
        records[record["pose"]] = record
    return Resumed(header, records)


def _parse(raw: bytes, *, crc: bool | None) -> Any:
    """A line's JSON object (CRC checked and removed when ``crc``), or None when unusable."""
    try:
        text = raw.decode("utf-8")
        # The one strict JSON reader: no duplicate keys, NaN, 1e400 or 64-bit overflow.
        obj = jsonfile.load_json(text, "journal line")
    except (UnicodeDecodeError, StrictError):
        return None
    if crc is None or not isinstance(obj, dict):
        return obj
    if crc:
        stated = obj.pop(CRC_KEY, None)
        if type(stated) is not int or not text.endswith("}"):
            return None
        try:
            body = json.dumps(obj, allow_nan=False)  # 1e400 reads as inf: not writable
        except ValueError:
            return None
        if zlib.crc32(body.encode()) != stated or encode_line(obj) != text + "\n":
            return None
    return obj


class _RecordCheck:
    """Checks one record against the header (and the plan): returns what is wrong, or ""."""

    def __init__(
        self, header: dict, plan: np.ndarray | None, convention: JointConvention = _IDENTITY
    ) -> None:
        self.convention = convention
        poses = header.get("poses")
        self.poses = poses if type(poses) is int and poses > 0 else None
        if plan is not None:
            self.poses = len(plan)
        readings = header.get("readings")
        self.readings = readings if type(readings) is int and readings > 0 else None
        self.plan = plan

    def __call__(self, record: Any) -> str:
        if not isinstance(record, dict):
            return "not a JSON object"
        pose = record.get("pose")
        if type(pose) is not int:
            return f"pose must be a whole number, got {pose!r}"
        if pose < 0 or (self.poses is not None and pose >= self.poses):
            return f"pose {pose} is not a row of the plan (0..{(self.poses or 1) - 1})"
        status = record.get("status")
        if status == "failed":
            return self._failed(record)
        if status != "measured":
            return f"pose {pose}: status must be 'measured' or 'failed', got {status!r}"
        return self._measured(record, pose)

    def _failed(self, record: dict) -> str:
        if not isinstance(record.get("reason"), str):
            return f"pose {record['pose']}: a failed pose needs its reason (text)"
        problem = _count(record, "attempts", 1)
        causes = record.get("causes", {})
        if not problem and not (
            isinstance(causes, dict) and all(type(n) is int and n >= 0 for n in causes.values())
        ):
            problem = f"pose {record['pose']}: causes must map a failure class to a count"
        return problem

    def _measured(self, record: dict, pose: int) -> str:
        q = _vector(record, "q_rad", 6, math.tau * 2)
        if isinstance(q, str):
            return q
        # The line holds the controller's angles; the record, from here on, the model's.
        q = self.convention.to_model(np.asarray(q, dtype=float)).tolist()
        record["q_rad"] = q
        for key, size, bound in (("point_mm", 3, MAX_COORD_MM), ("std_mm", 3, MAX_COORD_MM)):
            value = _vector(record, key, size, bound)
            if isinstance(value, str):
                return value
        if any(v < 0 for v in record["std_mm"]):
            return f"pose {pose}: std_mm must be >= 0, got {record['std_mm']}"
        if "rotvec_rad" in record:
            value = _vector(record, "rotvec_rad", 3, 2 * math.pi)
            if isinstance(value, str):
                return value
        for key, least in (("n_readings", 1), ("rejected", 0), ("attempts", 1)):
            problem = _count(record, key, least)
            if problem:
                return problem
        # Journals written before outliers were recorded have no count: read as none.
        outliers = record.get("outliers", 0)
        if type(outliers) is not int or not 0 <= outliers <= record["rejected"]:
            got = _short(outliers)
            return f"pose {pose}: outliers must be a whole number in [0, rejected], got {got}"
        if self.readings is not None and record["n_readings"] > self.readings:
            return f"pose {pose}: {record['n_readings']} readings, the run takes {self.readings}"
        if not isinstance(record.get("timestamp"), str):
            return f"pose {pose}: timestamp must be text"
        if self.plan is not None:
            off = float(np.max(np.abs(np.asarray(q) - self.plan[pose])))
            if not off <= JOINT_MATCH_RAD:
                return (
                    f"pose {pose}: joints differ from the plan's row {pose} by {off:.3g} rad "
                    f"(more than {JOINT_MATCH_RAD} rad)"
                )
        return ""


def _vector(record: dict, key: str, size: int, bound: float) -> list[float] | str:
    value = record.get(key)
    if not (
        isinstance(value, list)
        and len(value) == size
        and all(type(v) in (int, float) and math.isfinite(v) and abs(v) <= bound for v in value)
    ):
        return (
            f"pose {record['pose']}: {key} must be {size} finite numbers within +-{bound:g}, "
            f"got {_short(value)}"
        )
    return value


def _count(record: dict, key: str, least: int) -> str:
    value = record.get(key)
    if type(value) is not int or not least <= value <= 10**9:
        got = _short(value)
        return f"pose {record['pose']}: {key} must be a whole number >= {least}, got {got}"
    return ""


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _lock(fh: IO[str], path: Path) -> None:
    """Hold an exclusive lock on the journal while this process writes it (released on close)."""
    try:
        fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        fh.close()
        raise JournalError(
            f"{path} is in use by another measure run: wait for it to end (or stop it), then resume"
        ) from None


def _truncate_partial_line(path: Path) -> None:
    """Cut a last line without its newline (a write a crash interrupted)."""
    data = path.read_bytes()
    end = data.rfind(b"\n") + 1
    if end != len(data):
        with open(path, "r+b") as fh:
            fh.truncate(end)
            os.fsync(fh.fileno())


def _fsync_dir(path: Path) -> None:
    """Make the new file's directory entry durable too."""
    fd = os.open(path.parent, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)
