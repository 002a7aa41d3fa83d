"""Raw-exchange recording: JSON lines the driver writes and the simulator replays.

File layout (one JSON object per line, UTF-8)::

    {"format": "calibrator.tracker-log", "version": 1, "started_utc": "2026-11-22T02:30:00Z"}
    {"t_s": 0.000412, "dir": "tx", "data": "1,ID?*6F2B\\r\\n"}
    {"t_s": 0.001030, "dir": "rx", "data": "OK,1,CALIBRATOR,TRACKER-SIM,SIM-0001,1.0*1A2B\\r\\n"}

``t_s`` is seconds since the recording started (monotonic clock), ``dir``
is ``tx`` (host to tracker) or ``rx`` (tracker to host), ``data`` is the raw
bytes exactly as written or read (a read chunk may hold part of a line, or
several lines), decoded as Latin-1 so every byte value survives JSON.
"""

from __future__ import annotations

import datetime as _dt
import json
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

LOG_FORMAT = "calibrator.tracker-log"
LOG_VERSION = 1


@dataclass(frozen=True)
class LogEntry:
    """One logged chunk: seconds since start, ``"tx"`` or ``"rx"``, raw bytes."""

    t_s: float
    direction: str
    data: bytes


class Recorder:
    """Append raw exchange chunks to a JSON-lines log.

    Parameters
    ----------
    sink : str, Path or text file
        Path to create (overwritten) or an open text file (not closed by us).
    clock : callable
        Monotonic clock in seconds.
    """

    def __init__(self, sink: str | Path | TextIO, clock: Callable[[], float] = time.monotonic):
        if isinstance(sink, str | Path):
            self._file: TextIO = open(sink, "w", encoding="utf-8")  # closed in close()
            self._owned = True
        else:
            self._file, self._owned = sink, False
        self._clock = clock
        self._t0 = clock()
        started = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ")
        self._write({"format": LOG_FORMAT, "version": LOG_VERSION, "started_utc": started})

    def log(self, direction: str, data: bytes) -> None:
        """Record one chunk; ``direction`` is ``"tx"`` or ``"rx"``; empty chunks are skipped."""
        if data:
            t_s = round(self._clock() - self._t0, 6)
            self._write({"t_s": t_s, "dir": direction, "data": data.decode("latin-1")})

    def _write(self, obj: dict) -> None:
        self._file.write(json.dumps(obj) + "\n")
        self._file.flush()  # a crash must not lose the exchange that caused it

    def close(self) -> None:
        if self._owned:
            self._file.close()


def read_log(path: str | Path) -> list[LogEntry]:
    """Load a log written by :class:`Recorder`.

    Raises
    ------
    ValueError
        If the header is missing or of another format/version, or an entry is malformed.
    """
    lines = Path(path).read_text(encoding="utf-8").splitlines()
    if not lines:
        raise ValueError(f"{path}: empty log")
    header = json.loads(lines[0])
    if header.get("format") != LOG_FORMAT or header.get("version") != LOG_VERSION:
        raise ValueError(f"{path}: not a {LOG_FORMAT} v{LOG_VERSION} file: {header}")
    entries = []
    for n, line in enumerate(lines[1:], start=2):
        obj = json.loads(line)
        if obj.get("dir") not in ("tx", "rx") or not isinstance(obj.get("data"), str):
            raise ValueError(f"{path}:{n}: malformed entry {line[:80]}")
        entries.append(LogEntry(float(obj["t_s"]), obj["dir"], obj["data"].encode("latin-1")))
    return entries


def group_exchanges(entries: list[LogEntry]) -> list[tuple[bytes, list[bytes]]]:
    """Pair each written frame with the chunks read before the next write.

    Chunks read before the first write are attached to the first exchange.
    """
    exchanges: list[tuple[bytes, list[bytes]]] = []
    leading: list[bytes] = []
    for entry in entries:
        if entry.direction == "tx":
            exchanges.append((entry.data, leading))
            leading = []
            continue
        if exchanges:
            exchanges[-1][1].append(entry.data)
        else:
            leading.append(entry.data)
    return exchanges
