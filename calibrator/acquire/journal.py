"""The append-only journal beside a session being measured: crash safety and ``--resume``.

One JSON object per line. The first line is the header: which plan, robot and
tracker the run belongs to, and the session metadata. Every further line is
one finished pose (measured, or failed after its retries), written, flushed
and fsynced before the robot moves again, so a crash (even SIGKILL) loses at
most the pose in progress. A line cut short by a crash is dropped on resume.

Floats go through JSON's shortest round-trip repr, so a row read back from the
journal is bit-for-bit the row that was measured.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

from calibrator.errors import CalibrationError

FORMAT = "calibrator.journal"
VERSION = 1
#: Header keys that must match for a resume: the run's identity.
IDENTITY_KEYS = ("plan_sha256", "robot", "tracker", "readings")


class JournalError(CalibrationError):
    """A journal is unreadable or belongs to another run."""


def journal_path(output) -> Path:
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
    """

    def __init__(self, path: Path, fh):
        self.path = path
        self._fh = fh

    @classmethod
    def create(cls, path, header: dict) -> Journal:
        """Start a journal; refuses to replace an existing one (it may hold a run's poses)."""
        path = Path(path)
        try:
            fh = open(path, "x", encoding="utf-8")  # noqa: SIM115  closed by close()
        except FileExistsError:
            raise JournalError(
                f"{path} exists (an unfinished run): pass --resume to continue it, "
                "or remove it to start over"
            ) from None
        journal = cls(path, fh)
        journal._write({"format": FORMAT, "version": VERSION, **header})
        _fsync_dir(path)
        return journal

    @classmethod
    def resume(cls, path, header: dict) -> tuple[Journal, Resumed]:
        """Reopen a journal for appending after checking it belongs to this run.

        Raises
        ------
        JournalError
            No journal, not a journal, or its plan, robot, tracker or reading
            count differ from ``header``.
        """
        path = Path(path)
        done = read(path)
        for key in IDENTITY_KEYS:
            if done.header.get(key) != header.get(key):
                raise JournalError(
                    f"{path} belongs to another run: its {key} is {done.header.get(key)!r}, "
                    f"this run's is {header.get(key)!r}"
                )
        _truncate_partial_line(path)
        return cls(path, open(path, "a", encoding="utf-8")), done  # noqa: SIM115

    def append(self, record: dict) -> None:
        """Write one finished pose durably (flush and fsync) before returning."""
        self._write(record)

    def _write(self, obj: dict) -> None:
        self._fh.write(json.dumps(obj, allow_nan=False) + "\n")
        self._fh.flush()
        os.fsync(self._fh.fileno())

    def close(self) -> None:
        if not self._fh.closed:
            self._fh.close()

    def __enter__(self) -> Journal:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def read(path) -> Resumed:
    """Read a journal: its header and the last record of each pose.

    Raises
    ------
    JournalError
        Missing file, or a first line that is not a journal header.
    """
    path = Path(path)
    if not path.is_file():
        raise JournalError(f"no journal to resume: {path} not found")
    with open(path, encoding="utf-8") as fh:
        lines = fh.read().split("\n")
    try:
        header = json.loads(lines[0])
    except ValueError:
        header = None
    if not isinstance(header, dict) or header.get("format") != FORMAT:
        raise JournalError(f"{path} is not a calibrator journal")
    if header.get("version") != VERSION:
        raise JournalError(f"{path}: journal version {header.get('version')!r} is not supported")
    records = {}
    # The last element is "" after a complete file, or a line a crash cut short.
    for number, line in enumerate(lines[1:-1], start=2):
        try:
            record = json.loads(line)
            records[int(record["pose"])] = record
        except (ValueError, KeyError, TypeError):
            raise JournalError(f"{path}: line {number} is damaged") from None
    return Resumed(header, records)


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
