"""Continuous measurement on the line protocol: ``STREAM``, its time-stamped ticks, ``STOP``.

:meth:`drivers.tracker.line.device.LaserTracker.stream` starts a stream and
returns a :class:`ReadingStream`, which hands over the ticks in order with the
same integrity as single readings:

- every frame's CRC is checked; a corrupted line is a lost tick, counted,
  never a reading;
- ticks are numbered: a gap is counted in :attr:`ReadingStream.lost`, and a
  tick that does not move forward, or a frame of an earlier stream, is
  dropped (never a stale point);
- a tick without a reading (beam broken, no target, out of range) comes as
  a :class:`StreamSample` with ``reading`` None and the code, so a break is
  marked where it happened;
- a stream that sends nothing for ``stall_timeout_s`` raises
  :class:`~drivers.tracker.line.errors.StreamStalled` (after sending ``STOP``).

Positions are mm in the tracker frame, orientations rad, stamps the tracker's
clock in microseconds.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from drivers.tracker.errors import ConnectionLost, DriverError, TrackerTimeout
from drivers.tracker.line.errors import StreamStalled
from drivers.tracker.line.link import Link
from drivers.tracker.line.protocol import ErrorCode, Reading


class StreamOwner(Protocol):
    """What a stream needs of its driver (:class:`~drivers.tracker.line.device.LaserTracker`)."""

    @property
    def link(self) -> Link: ...

    def stop(self) -> None: ...


#: Ticks a stream may miss in a row before it counts as stalled (at least 0.5 s).
STALL_TICKS = 20


@dataclass(frozen=True)
class StreamSample:
    """One tick of a stream.

    Attributes
    ----------
    n : int
        Tick number, from 1.
    device_time_us : int
        Tracker clock at the tick, microseconds.
    reading : Reading or None
        The reading, or None when the tracker had none at this tick.
    code : int
        0 with a reading, else the reason (``ErrorCode.BEAM_BROKEN``, ...).
    """

    n: int
    device_time_us: int
    reading: Reading | None
    code: int

    @property
    def beam_broken(self) -> bool:
        return self.code in (ErrorCode.BEAM_BROKEN, ErrorCode.NO_TARGET)


@dataclass(frozen=True)
class StreamRecord:
    """A stream's ticks as arrays (what :meth:`ReadingStream.collect` returns).

    Attributes
    ----------
    n : ndarray of int, shape (K,)
        Tick numbers, strictly increasing (gaps are lost ticks).
    t_us : ndarray of int, shape (K,)
        Tracker clock at each tick, microseconds.
    point_mm : ndarray, shape (K, 3)
        Positions, tracker frame, mm; NaN at ticks without a reading.
    rotvec_rad : ndarray, shape (K, 3), or None
        Probe orientations (probe to tracker frame), rad, NaN where none;
        None from a reflector.
    code : ndarray of int, shape (K,)
        0 with a reading, else why there is none.
    accurate : ndarray of bool, shape (K,)
        The reading is flagged ``ACC``.
    """

    n: np.ndarray
    t_us: np.ndarray
    point_mm: np.ndarray
    rotvec_rad: np.ndarray | None
    code: np.ndarray
    accurate: np.ndarray


class ReadingStream:
    """A running stream (made by :meth:`LaserTracker.stream`); iterate it for its ticks.

    Use it as a context manager, so the stream is stopped however the block ends.

    Attributes
    ----------
    stream_id : int
        Sequence number of the ``STREAM`` command: frames carry it.
    rate_hz : int
        Requested tick rate.
    lost : int
        Ticks missing from the numbering so far (dropped or corrupted frames,
        ticks the tracker skipped).
    stale : int
        Frames of this stream dropped because their tick number did not move forward.
    ended : bool
        The stream is over (its count reached, stopped, or failed).
    """

    def __init__(
        self, tracker: StreamOwner, stream_id: int, rate_hz: int, stall_timeout_s: float
    ) -> None:
        self._tracker = tracker
        self.stream_id = stream_id
        self.rate_hz = rate_hz
        self.stall_timeout_s = stall_timeout_s
        self.lost = 0
        self.stale = 0
        self.ended = False
        self._last_n = 0

    def next(self) -> StreamSample | None:
        """The next tick, or None once the stream has ended.

        Raises
        ------
        StreamStalled
            No frame of this stream within ``stall_timeout_s`` (``STOP`` is sent).
        ConnectionLost
            The transport failed; the stream is over (the driver reconnects at its
            next command, which finds the port gone).
        """
        while not self.ended:
            deadline = time.monotonic() + self.stall_timeout_s
            try:
                frame = self._tracker.link.read_stream_frame(self.stream_id, deadline)
            except TrackerTimeout as exc:
                self._stop_quietly()
                raise StreamStalled(
                    f"stream {self.stream_id}: no tick within {self.stall_timeout_s:g} s "
                    f"after tick {self._last_n}; stopped"
                ) from exc
            except ConnectionLost:
                self.ended = True  # the driver's next command finds the port gone and reconnects
                raise
            if frame.end:
                self.lost += max(frame.n - self._last_n, 0)
                self.ended = True
                return None
            if frame.n <= self._last_n:
                self.stale += 1
                self._tracker.link.counters.stream_frames_dropped += 1
                continue
            self.lost += frame.n - self._last_n - 1
            self._last_n = frame.n
            return StreamSample(frame.n, frame.device_time_us, frame.reading, frame.code)
        return None

    def __iter__(self) -> Iterator[StreamSample]:
        while (sample := self.next()) is not None:
            yield sample

    def collect(self, count: int) -> StreamRecord:
        """Read up to ``count`` ticks (fewer if the stream ends) into arrays."""
        samples = []
        for sample in self:
            samples.append(sample)
            if len(samples) >= count:
                break
        return record(samples)

    def stop(self) -> None:
        """``STOP``: end the stream; ticks still on their way are dropped and counted."""
        if not self.ended:
            self.ended = True
            self._tracker.stop()

    def _stop_quietly(self) -> None:
        """Stop after a failure: the failure is what the caller hears about."""
        try:
            self.stop()
        except DriverError:
            pass  # the stall is reported; a tracker that cannot stop will show at its next command

    def __enter__(self) -> ReadingStream:
        return self

    def __exit__(self, *exc) -> None:
        if exc[0] is None:
            self.stop()
        else:
            self._stop_quietly()


def record(samples: list[StreamSample]) -> StreamRecord:
    """Arrays of a list of ticks (see :class:`StreamRecord`)."""
    k = len(samples)
    point = np.full((k, 3), np.nan)
    six_dof = any(s.reading is not None and s.reading.rotvec_rad is not None for s in samples)
    rot = np.full((k, 3), np.nan) if six_dof else None
    accurate = np.zeros(k, dtype=bool)
    for i, s in enumerate(samples):
        if s.reading is not None:
            point[i] = s.reading.point_mm
            accurate[i] = s.reading.accurate
            if rot is not None and s.reading.rotvec_rad is not None:
                rot[i] = s.reading.rotvec_rad
    return StreamRecord(
        n=np.array([s.n for s in samples], dtype=np.int64),
        t_us=np.array([s.device_time_us for s in samples], dtype=np.int64),
        point_mm=point,
        rotvec_rad=rot,
        code=np.array([s.code for s in samples], dtype=np.int64),
        accurate=accurate,
    )
