"""Laser-tracker driver on pyserial: connect, initialise, single readings, streams, stop.

The same code runs on ``/dev/ttyUSB0``, ``socket://host:port`` and
``rfc2217://host:port`` because the transport comes from
``serial.serial_for_url``; or the caller hands in an already-open
serial-like object. All quantities are mm and rad in the tracker frame.
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

import serial

from calibrator.acquire import ports
from drivers.tracker.base import Environment, OpenOptions
from drivers.tracker.errors import (
    ConnectionLost,
    FrameError,
    IdentityChanged,
    LinkDropped,
    TrackerError,
    TrackerGone,
    TrackerTimeout,
)
from drivers.tracker.line.link import TRANSPORT_ERRORS, Link, LinkCounters, SerialLike
from drivers.tracker.line.protocol import (
    ErrorCode,
    Reading,
    Reply,
    format_number,
    parse_number,
    parse_reading,
)
from drivers.tracker.line.stream import STALL_TICKS, ReadingStream
from drivers.tracker.recording import Recorder
from drivers.urls import LOGGING
from drivers.urls import parse as parse_url


@dataclass(frozen=True)
class Identity:
    """What ``ID?`` reports; vendor, model and serial must survive a reconnect."""

    vendor: str
    model: str
    serial: str
    firmware: str

    @property
    def key(self) -> tuple[str, str, str]:
        return (self.vendor, self.model, self.serial)


@dataclass(frozen=True)
class Status:
    """What ``STAT?`` reports.

    Attributes
    ----------
    state : str
        ``READY``, ``NOT_READY`` or ``BUSY``.
    initialised : bool
    beam_locked : bool
        The beam is on a target.
    probe_6dof : bool
        Readings carry orientation.
    mode : str
        Measurement profile (``FAST``, ``STANDARD``, ``PRECISE``).
    """

    state: str
    initialised: bool
    beam_locked: bool
    probe_6dof: bool
    mode: str


class LaserTracker:
    """Driver for a tracker speaking the protocol in ``docs/tracker-protocol.md``.

    Parameters
    ----------
    port : str or SerialLike
        A pyserial URL (opened by :meth:`connect`, reopened by reconnects) or an
        already-open serial-like object (reconnect then uses its ``close``/``open``).
    timeout_s : float
        Deadline of ordinary commands, s.
    measure_timeout_s : float
        Deadline of ``MEAS``, s (a stationary reading may average for a while).
    init_timeout_s : float
        Deadline of ``INIT``, s (a real tracker moves its head for tens of seconds).
    record : str, Path or text file, optional
        Log every raw exchange there as JSON lines (see :mod:`drivers.tracker.recording`).
    reconnect_attempts : int
        Bounded reconnects after the transport fails (0 disables reconnecting).
    reconnect_delay_s : float
        Pause before each reconnect attempt, s.
    on_event : callable, optional
        Called with each unsolicited ``EV`` frame.
    environment : Environment, optional
        Meteo data :meth:`connect` sends when it is given none.
    """

    capabilities = frozenset({ports.INITIALISE, ports.REPORTS_CONDITIONS})

    def __init__(
        self,
        port: str | SerialLike,
        *,
        timeout_s: float = 1.0,
        measure_timeout_s: float = 2.0,
        init_timeout_s: float = 120.0,
        record: str | Path | TextIO | None = None,
        reconnect_attempts: int = 3,
        reconnect_delay_s: float = 0.2,
        on_event: Callable[[Reply], None] | None = None,
        environment: Environment | None = None,
    ):
        self._url = port if isinstance(port, str) else None
        self._port: SerialLike | None = None if isinstance(port, str) else port
        self.timeout_s = timeout_s
        self.measure_timeout_s = measure_timeout_s
        self.init_timeout_s = init_timeout_s
        self.reconnect_attempts = reconnect_attempts
        self.reconnect_delay_s = reconnect_delay_s
        self._recorder = Recorder(record) if record is not None else None
        self._on_event = on_event
        self.environment = environment
        self._link: Link | None = None
        self._events: deque[Reply] = deque(maxlen=256)  # survives reconnects
        # Sequence numbers continue across reconnects, so a late reply to a command
        # lost in a reconnect can never match a command sent after it.
        self._counters = LinkCounters()
        self._lost = False
        self.identity: Identity | None = None
        self.last_status: Status | None = None
        # Settings re-applied after a reconnect, in order: (command, args).
        self._settings: dict[str, tuple[str, ...]] = {}

    # ------------------------------------------------------------ lifecycle

    def connect(self, environment: Environment | None = None, mode: str | None = None) -> Status:
        """Open the transport, identify, set units (mm, rad), environment and mode, read status.

        Never initialises: call :meth:`initialise` when :attr:`Status.initialised` is False.
        Who answered is :attr:`identity` (and :attr:`device_id`) afterwards.

        Returns
        -------
        Status
        """
        self._closed = False  # an explicit connect reopens a closed driver
        self._open()
        self.identity = self.query_identity()
        reply = self._apply("UNITS", "MM", "RAD")
        if reply.fields != ("MM", "RAD"):  # every reading is parsed as mm and rad
            raise FrameError(f"tracker did not confirm UNITS,MM,RAD: {reply.fields!r}")
        environment = environment or self.environment
        if environment is not None:
            self.set_environment(environment)
        if mode is not None:
            self.set_mode(mode)
        return self.status()

    @property
    def device_id(self) -> str:
        """``vendor:model:serial`` of the tracker that answered :meth:`connect` ("" before)."""
        return ":".join(self.identity.key) if self.identity is not None else ""

    def close(self) -> None:
        """Close the transport if we opened it, and the recording.

        A closed driver stays closed: a later command raises
        :class:`TrackerGone` instead of reopening the port.
        """
        self._closed = True
        if self._url is not None and self._port is not None:
            try:
                self._port.close()
            except TRANSPORT_ERRORS:
                pass  # closing a vanished port: nothing left to release
        self._link = None
        if self._recorder is not None:
            self._recorder.close()
            self._recorder = None

    def __enter__(self) -> LaserTracker:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    @property
    def events(self) -> deque[Reply]:
        """Unsolicited ``EV`` frames received so far (most recent last, at most 256)."""
        return self._events

    @property
    def stale_replies(self) -> int:
        """Replies dropped because they answered an earlier command (late replies), all links."""
        return self._counters.stale_replies

    @property
    def discarded_bytes(self) -> int:
        """Received bytes thrown away (junk, over-long lines, input flushed at reconnects)."""
        return self._counters.discarded_bytes

    @property
    def link(self) -> Link:
        """The transaction layer (for simulator-only commands and diagnostics)."""
        if self._link is None:
            raise ConnectionLost("not connected: call connect() first")
        return self._link

    # ------------------------------------------------------------ commands

    def query_identity(self) -> Identity:
        """``ID?``: vendor, model, serial number, firmware."""
        return _parse_identity(self._query("ID?", idempotent=True))

    def status(self) -> Status:
        """``STAT?``: readiness, initialisation, beam lock, probe type, mode."""
        reply = self._query("STAT?", idempotent=True)
        self.last_status = _parse_status(reply)
        return self.last_status

    def set_environment(self, environment: Environment) -> None:
        """``ENV,T,P,H``: temperature degC, pressure hPa, relative humidity %."""
        self._apply(
            "ENV",
            format_number(environment.temperature_c, 2),
            format_number(environment.pressure_hpa, 2),
            format_number(environment.humidity_pct, 1),
        )

    def conditions(self) -> dict | None:
        """``COND?``: the air the station measures, time since power-on, warmed up.

        Returns
        -------
        dict or None
            ``air_temperature_c``, ``air_pressure_hpa``, ``air_humidity_pct``,
            ``on_s`` (s since power-on) and ``warmed_up`` (bool); None from a
            tracker (or bridge) that does not know the query.
        """
        try:
            reply = self._query("COND?", idempotent=True)
        except TrackerError as exc:
            if exc.code == ErrorCode.UNKNOWN_COMMAND:
                return None
            raise
        f = reply.fields
        if len(f) != 5 or f[4] not in ("0", "1"):
            raise FrameError(f"bad COND? reply fields {f!r}")
        t, p, h, on_s = (parse_number(v) for v in f[:4])
        return {
            "air_temperature_c": t,
            "air_pressure_hpa": p,
            "air_humidity_pct": h,
            "on_s": on_s,
            "warmed_up": f[4] == "1",
        }

    def set_mode(self, mode: str) -> None:
        """``MODE,<FAST|STANDARD|PRECISE>``: stationary measurement profile."""
        self._apply("MODE", mode)

    def initialise(self, timeout_s: float | None = None) -> None:
        """``INIT``: home and initialise the tracker head (slow; moves the head).

        Only ever sent when the caller asks; reconnects never do it.
        """
        self._query("INIT", idempotent=False, timeout_s=timeout_s or self.init_timeout_s)

    def measure(self, timeout_s: float | None = None) -> Reading:
        """``MEAS``: one stationary reading with its status flag.

        Returns
        -------
        Reading
            ``point_mm`` shape (3,) in the tracker frame, mm; ``rotvec_rad``
            shape (3,) for a 6-DoF probe, else None.

        Raises
        ------
        BeamBroken, NotInitialised, TargetUnstable, TrackerError
            The tracker refused (typed by its error code).
        TrackerTimeout, FrameError, ChecksumError
            No usable reply; the reading is lost and never re-requested here.
        LinkDropped
            The transport failed and a reconnect brought it back; this reading
            is lost (a :class:`~calibrator.acquire.ports.ReadingLost`) and not repeated.
        TrackerGone
            The transport failed and the bounded reconnect did not bring it
            back, or another tracker answered (a
            :class:`~calibrator.acquire.ports.TrackerUnavailable`).
        """
        reply = self._query("MEAS", idempotent=False, timeout_s=timeout_s or self.measure_timeout_s)
        return parse_reading(reply.fields)

    def stop(self) -> None:
        """``STOP``: abort any measurement in progress."""
        self._query("STOP", idempotent=True)

    def stream(
        self, rate_hz: int, count: int | None = None, *, stall_timeout_s: float | None = None
    ) -> ReadingStream:
        """``STREAM``: continuous time-stamped readings at ``rate_hz`` until stopped.

        Parameters
        ----------
        rate_hz : int
            Ticks per second, 1..1000.
        count : int, optional
            Ticks to send before the tracker ends the stream by itself.
        stall_timeout_s : float, optional
            Longest silence of a running stream before it counts as stalled, s
            (default ``STALL_TICKS`` ticks, at least 0.5 s).

        Returns
        -------
        ReadingStream
            Iterate it for :class:`~drivers.tracker.line.stream.StreamSample`;
            use it in a ``with`` block so that it is stopped.

        Raises
        ------
        TrackerError, NotInitialised, TrackerTimeout, LinkDropped, TrackerGone
            As :meth:`measure`; after a lost or unreadable reply ``STOP`` is
            sent, in case the tracker started.
        """
        args = [str(int(rate_hz))] + ([str(int(count))] if count is not None else [])
        try:
            self._query("STREAM", *args, idempotent=False)
        except (TrackerTimeout, FrameError, LinkDropped):
            try:
                self.stop()
            except (ConnectionLost, TrackerTimeout, FrameError, TrackerError):
                pass  # the failure to start is what the caller hears about
            raise
        if stall_timeout_s is None:
            stall_timeout_s = max(0.5, STALL_TICKS / rate_hz)
        return ReadingStream(self, self.link.last_seq, int(rate_hz), stall_timeout_s)

    def send(self, command: str, *args: str, timeout_s: float | None = None) -> Reply:
        """Send any command (e.g. simulator-only ``SIM,...``) and return the ``OK`` reply.

        Not retried and not re-applied after a reconnect.
        """
        return self._query(command, *args, idempotent=False, timeout_s=timeout_s)

    # ------------------------------------------------------------ machinery

    def _apply(self, command: str, *args: str) -> Reply:
        """Send a setting and remember it for re-applying after a reconnect."""
        reply = self._query(command, *args, idempotent=True)
        self._settings[command] = args
        return reply

    def _query(
        self, command: str, *args: str, idempotent: bool, timeout_s: float | None = None
    ) -> Reply:
        """One transaction with the recovery policy.

        A garbled reply or a lost connection is retried once for idempotent
        commands; for others (MEAS, INIT) the error is raised, so a reading is
        never silently replaced by a second one.
        """
        timeout_s = timeout_s or self.timeout_s
        if getattr(self, "_closed", False):
            raise TrackerGone(f"{command}: the tracker driver was closed")
        for attempt in (0, 1):
            if self._lost or self._link is None:
                self._reconnect()
            try:
                return self.link.transact(command, *args, timeout_s=timeout_s)
            except FrameError:
                if not idempotent or attempt:
                    raise
            except ConnectionLost as exc:
                if isinstance(exc, IdentityChanged):
                    raise
                self._lost = True
                self._reconnect()  # raises ConnectionLost when it cannot
                if not idempotent or attempt:
                    raise LinkDropped(
                        f"connection lost during {command}; reconnected, command not repeated"
                    ) from exc
        raise AssertionError("unreachable")

    def _open(self) -> None:
        if self._url is not None:
            if self._port is not None:
                try:
                    self._port.close()
                except TRANSPORT_ERRORS:
                    pass  # the old port is already gone
                self._port = None
            try:
                # The link sets write_timeout before each write (from the deadline).
                self._port = serial.serial_for_url(self._url, timeout=self.timeout_s)
            except (*TRANSPORT_ERRORS, ValueError) as exc:
                raise ConnectionLost(f"cannot open {self._url}: {exc}") from exc
        elif self._port is None:
            raise ConnectionLost("no transport")
        self._link = self._new_link(self._port)
        self._link.discard_input()  # bytes from an earlier session are not ours
        self._lost = False

    def _new_link(self, port: SerialLike) -> Link:
        return Link(
            port,
            recorder=self._recorder,
            on_event=self._on_event,
            events=self._events,
            counters=self._counters,
        )

    def _reopen_handed_port(self) -> None:
        """Reopen a transport we were handed (pyserial objects keep their port name)."""
        port = self._port
        if port is None or not hasattr(port, "open"):
            raise ConnectionLost("transport lost and it cannot be reopened")
        try:
            port.close()
            port.open()
        except (*TRANSPORT_ERRORS, ValueError) as exc:
            raise ConnectionLost(f"cannot reopen transport: {exc}") from exc
        self._link = self._new_link(port)
        self._link.discard_input()
        self._lost = False

    def _reconnect(self) -> None:
        """Bounded reconnect: reopen, check identity, re-apply settings, read status.

        Never sends INIT. Raises ConnectionLost (or IdentityChanged) when it fails.
        """
        if self.identity is None:
            raise ConnectionLost("not connected: call connect() first")
        last: Exception | None = None
        for _ in range(self.reconnect_attempts):
            time.sleep(self.reconnect_delay_s)
            try:
                if self._url is not None:
                    self._open()
                else:
                    self._reopen_handed_port()
                link = self.link
                ident = _parse_identity(link.transact("ID?", timeout_s=self.timeout_s))
                if ident.key != self.identity.key:
                    self._lost = True
                    raise IdentityChanged(
                        f"reconnected to {ident.key}, expected {self.identity.key}"
                    )
                for command, args in self._settings.items():
                    link.transact(command, *args, timeout_s=self.timeout_s)
                self.last_status = _parse_status(link.transact("STAT?", timeout_s=self.timeout_s))
                return
            except IdentityChanged:
                raise
            except (ConnectionLost, TrackerTimeout, FrameError) as exc:
                last = exc
                self._lost = True
        raise TrackerGone(
            f"connection lost; {self.reconnect_attempts} reconnect attempts failed: {last}"
        ) from last


def _parse_identity(reply: Reply) -> Identity:
    if len(reply.fields) != 4:
        raise FrameError(f"ID? reply has {len(reply.fields)} fields, expected 4")
    return Identity(*reply.fields)


def _parse_status(reply: Reply) -> Status:
    f = reply.fields
    flags = ("0", "1")
    if len(f) != 5 or f[1] not in flags or f[2] not in flags or f[3] not in ("P3", "P6"):
        raise FrameError(f"bad STAT? reply fields {f!r}")
    return Status(f[0], f[1] == "1", f[2] == "1", f[3] == "P6", f[4])


#: Query parameters pyserial's network transports take (``logging`` is checked
#: here: pyserial reports a bad level, and a port above 65535, as the level list).
_URL_PARAMS: dict = {
    "socket": {"logging": LOGGING},
    "rfc2217": {"logging": LOGGING, "ign_set_control": None, "poll_modem": None, "timeout": None},
}


def check_url(url: str) -> None:
    """Refuse a malformed ``socket://HOST:PORT``, ``rfc2217://HOST:PORT`` or ``loop://``.

    ``loop://`` takes ``logging`` only; device paths are left to pyserial.

    Raises
    ------
    ValueError
        Missing host, missing or out-of-range port, unknown parameter.
    """
    kind = url.split("://", 1)[0].lower() if "://" in url else ""
    if kind == "loop":  # pyserial's loopback: no host, logging only
        parse_url(url, kind, host=False, params={"logging": LOGGING})
    elif kind in _URL_PARAMS:
        parse_url(url, kind, port="required", params=_URL_PARAMS[kind])


def open_url(url: str, options: OpenOptions) -> LaserTracker:
    """The registry's opener for the line protocol (device paths and pyserial URLs)."""
    if options.world is not None:
        raise ValueError(f"{url}: simulator options need --tracker sim")
    check_url(url)
    # Standard air until the user's meteo is wired in: what measure always sent.
    return LaserTracker(url, record=options.record, environment=Environment())
