"""Continuous measurement on emScon: continuous time and distance results as ticks.

:meth:`drivers.tracker.emscon.device.EmsconTracker.stream` sets a continuous
mode (``ES_MM_ContinuousTime``: a point every ``lTimeSeparation`` ms;
``ES_MM_ContinuousDistance``: a point each time the target has moved
``dSpatialDistance``; their 6-DoF twins for a probe, whose records carry its
orientation), starts it and returns an :class:`EmsconReadingStream`, which has
the surface of the line protocol's
:class:`~drivers.tracker.line.stream.ReadingStream` (``next``, iteration,
``collect``, ``stop``, ``lost``, ``stale``, ``ended``, a context manager), so
a caller can use either. The integrity rules are the same, adapted to what
emScon carries:

- emScon has no sequence number and no checksum (TCP's own is all there
  is): in time mode a record's tick number comes from its time stamp, ``n =
  1 + round((t - t_first) / separation)``, and a gap in ``n`` is counted in
  :attr:`EmsconReadingStream.lost`, never filled. In distance mode points
  come when the target has moved, not on a clock, so nothing shows a lost
  record: ticks are numbered in the order they arrive and ``lost`` stays 0.
  In both, a record whose stamp does not move forward (a repeat, a packet of
  an earlier stream) is dropped and counted in
  :attr:`EmsconReadingStream.stale`, so a stale point never passes;
- a record with impossible values (NaN, beyond 1 km) is dropped and counted
  in ``bad`` (its tick is then lost), as a corrupted line is on the line
  protocol;
- a beam break (``ES_DT_Error`` with ``ES_RS_MeasurementStatusNotReady`` or
  the ``ES_SSC_MeasStatus_NotReady`` event) is handed over as a sample with
  ``reading`` None and that status as its ``code``, at the tick after the
  last one; the ticks the beam stays broken are counted in ``broken``, not
  in ``lost``, and readings resume when results do;
- a stream that sends nothing for ``stall_timeout_s`` raises
  :class:`~drivers.tracker.line.errors.StreamStalled` (after
  ``StopMeasurement``). In distance mode a target held still sends nothing
  either: the timeout is how long the caller lets it rest.

Positions are mm in the server's frame; stamps the server's clock in
microseconds (``lTime1`` s and ``lTime2`` us, see docs/leica-emscon.md).
"""

from __future__ import annotations

import time
from collections import deque
from dataclasses import dataclass
from typing import Protocol

from drivers.tracker.emscon import protocol as pk
from drivers.tracker.emscon.errors import ConnectionLost, FrameError, TrackerTimeout
from drivers.tracker.emscon.link import EmsconLink
from drivers.tracker.emscon.reading import EmsconReading
from drivers.tracker.line.errors import StreamStalled
from drivers.tracker.streaming import SampleStream


class StreamOwner(Protocol):
    """What a stream needs of its driver (:class:`~drivers.tracker.emscon.device.EmsconTracker`)."""

    def stream_link(self) -> EmsconLink: ...

    def stream_reading(
        self, packet: pk.MultiMeasResult, record: pk.MeasValue, t_us: int
    ) -> EmsconReading | None: ...

    def stop_stream(self) -> None: ...


#: Ticks a stream may miss in a row before it counts as stalled (at least 0.5 s).
STALL_TICKS = 20
#: Statuses that mean the beam is not on the reflector.
BEAM_BROKEN_STATUS = frozenset(
    {pk.ResultStatus.MEASUREMENT_STATUS_NOT_READY, pk.ResultStatus.SYSTEM_NOT_READY_FOR_MEASUREMENT}
)


@dataclass(frozen=True)
class EmsconStreamSample:
    """One tick of a continuous stream (the line stream's ``StreamSample`` surface).

    Attributes
    ----------
    n : int
        Tick number from 1: from the record's stamp in time mode, in the order
        of arrival in distance mode.
    device_time_us : int
        Server clock at the tick, us (for a beam-break mark: the tick's due time
        in time mode; 1 us after the last point in distance mode).
    reading : EmsconReading or None
        The point, or None when the beam was broken at this tick.
    code : int
        0 with a reading, else the ``ES_ResultStatus`` why there is none.
    """

    n: int
    device_time_us: int
    reading: EmsconReading | None
    code: int

    @property
    def beam_broken(self) -> bool:
        return self.code in BEAM_BROKEN_STATUS


class EmsconReadingStream(SampleStream):
    """A running continuous measurement (time or distance mode); iterate it for its ticks.

    Attributes
    ----------
    stream_id : int
        Count of streams started by this driver (emScon packets carry no id).
    rate_hz : float or None
        Rate actually requested: ``1000 / separation_ms``; None in distance mode.
    separation_ms : int or None
        ``lTimeSeparation`` sent to the server, ms; None in distance mode.
    distance_mm : float or None
        ``dSpatialDistance`` sent to the server, mm; None in time mode.
    six_dof : bool
        The probe's 6-DoF mode: each reading carries the probe's orientation
        (``rotvec_rad``); False for a reflector (``rotvec_rad`` None: absent).
    count : int or None
        ``lNumberOfPoints`` (None: until stopped).
    lost, stale, bad, broken : int
        Ticks missing from the stamps; records dropped because their stamp did
        not move forward; records dropped for impossible values (a non-unit
        quaternion among them); ticks without a reading while the beam was
        broken. ``lost`` and ``broken`` need a clock: in distance mode they stay 0.
    ended : bool
        The stream is over (its count reached, stopped, or failed).
    """

    def __init__(
        self,
        tracker: StreamOwner,
        stream_id: int,
        separation_ms: int | None,
        count: int | None,
        stall_timeout_s: float,
        *,
        distance_mm: float | None = None,
        six_dof: bool = False,
    ) -> None:
        if (separation_ms is None) == (distance_mm is None):
            raise ValueError("a stream is in time mode (separation_ms) or distance mode")
        self._tracker = tracker
        self.stream_id = stream_id
        self.separation_ms = separation_ms
        self.rate_hz = None if separation_ms is None else 1000.0 / separation_ms
        self.distance_mm = distance_mm
        self.six_dof = six_dof
        self.count = count
        self.stall_timeout_s = stall_timeout_s
        self.lost = self.stale = self.bad = self.broken = 0
        self.ended = False
        self._last_n = 0
        self._points = 0  # readings handed over
        self._last_t: int | None = None
        self._base: tuple[int, int] | None = None  # (n before the first record, its stamp)
        self._beam_off = False  # from a break's mark until ES_SSC_MeasStatus_Ready
        self._gap_is_break = False  # from a break's mark until the next point
        self._pending: deque[EmsconStreamSample] = deque()

    # ------------------------------------------------------------ reading

    def next(self) -> EmsconStreamSample | None:
        """The next tick, or None once the stream has ended.

        Raises
        ------
        StreamStalled
            No packet within ``stall_timeout_s`` (``StopMeasurement`` is sent).
        ConnectionLost, FrameError
            The transport or the framing failed; the stream is over (the
            driver reconnects at its next command).
        """
        while not self._pending:
            if self.ended:
                return None
            deadline = time.monotonic() + self.stall_timeout_s
            try:
                packet = self._tracker.stream_link().read_stream_packet(deadline)
            except TrackerTimeout as exc:
                self._stop_quietly()
                raise StreamStalled(
                    f"emScon stream {self.stream_id}: no result within "
                    f"{self.stall_timeout_s:g} s after tick {self._last_n}; stopped"
                ) from exc
            except (ConnectionLost, FrameError):
                self.ended = True
                raise
            self._take(packet)
        sample = self._pending.popleft()
        if sample.reading is not None:
            self._points += 1
        # The server stops by itself after lNumberOfPoints: in time mode that many ticks
        # (with or without a point), in distance mode that many points sent.
        done = sample.n if self.separation_ms is not None else self._points
        if self.count is not None and done >= self.count:
            self.ended = True
            self._pending.clear()
        return sample

    def _take(self, packet: pk.MultiMeasResult | pk.ErrorResponse | pk.StatusChangeEvent) -> None:
        if isinstance(packet, pk.StatusChangeEvent):
            if packet.change == pk.StatusChange.MEAS_STATUS_NOT_READY:
                self._mark_break(pk.ResultStatus.MEASUREMENT_STATUS_NOT_READY)
            elif packet.change == pk.StatusChange.MEAS_STATUS_READY:
                self._beam_off = False
            return
        if isinstance(packet, pk.ErrorResponse):
            if packet.status in BEAM_BROKEN_STATUS:
                self._mark_break(packet.status)
            else:  # any other refusal ends the measurement: a mark with its code
                self._mark(packet.status)
                self.ended = True
            return
        if packet.status != pk.ResultStatus.ALL_OK:  # a failed packet: a mark, never points
            if packet.status in BEAM_BROKEN_STATUS:
                self._mark_break(packet.status)
            else:
                self._mark(packet.status)
            return
        for record in packet.records:
            self._record(packet, record)

    def _record(self, packet: pk.MultiMeasResult, record: pk.MeasValue) -> None:
        t_us = record.time_us
        if self._last_t is not None and t_us <= self._last_t:
            self.stale += 1  # a repeat or an older stream's record: never a point
            return
        if self.separation_ms is None:
            n = self._last_n + 1  # distance mode: no clock to number ticks by
        else:
            if self._base is None:
                self._base = (self._last_n, t_us)
            n = self._base[0] + 1 + round((t_us - self._base[1]) / (self.separation_ms * 1000))
            if n <= self._last_n:  # moved forward by less than half a tick: not a new tick
                self.stale += 1
                return
        reading = self._tracker.stream_reading(packet, record, t_us)
        if reading is None:
            self.bad += 1  # its tick stays missing and is counted lost below
            return
        gap = n - self._last_n - 1
        if self._gap_is_break:
            self.broken += gap
            self._gap_is_break = False
        else:
            self.lost += gap
        self._last_n, self._last_t = n, t_us
        self._pending.append(EmsconStreamSample(n, t_us, reading, 0))

    def _mark_break(self, status: int) -> None:
        if not self._beam_off:  # the event and the error of one break make one mark
            self._mark(status)
            self._beam_off = self._gap_is_break = True

    def _mark(self, status: int) -> None:
        n = self._last_n + 1
        # A mark is stamped at the tick it hit: in time mode the one after the last; in
        # distance mode no tick is due at any time, so 1 us after the last point (its
        # stamps still increase, and the next point must come later still).
        step_us = 1 if self.separation_ms is None else self.separation_ms * 1000
        t_us = -1 if self._last_t is None else self._last_t + step_us
        self._last_n = n
        if self._last_t is not None:
            self._last_t = t_us
        self._pending.append(EmsconStreamSample(n, t_us, None, int(status)))

    # ------------------------------------------------------------ stopping

    def stop(self) -> None:
        """``StopMeasurement``, then stationary mode again (results still on their way are
        dropped and counted in ``link.stream_packets_dropped``)."""
        if not self.ended:
            self.ended = True
        self._tracker.stop_stream()
