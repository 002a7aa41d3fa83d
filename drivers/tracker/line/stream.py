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
from dataclasses import dataclass
from typing import Protocol

from drivers.tracker.errors import ConnectionLost, TrackerTimeout
from drivers.tracker.line.errors import StreamStalled
from drivers.tracker.line.link import Link
from drivers.tracker.line.protocol import ErrorCode, Reading
from drivers.tracker.streaming import SampleStream


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


class ReadingStream(SampleStream):
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

    def stop(self) -> None:
        """``STOP``: end the stream; ticks still on their way are dropped and counted."""
        if not self.ended:
            self.ended = True
            self._tracker.stop()
