"""Leica emScon adapter behind the ``Tracker`` port: connect, status, stationary readings.

::

    tracker = EmsconTracker("192.168.0.1", 700, environment=Environment(21.3, 1002.0, 45.0))
    tracker.connect()            # units mm/rad/degC/hPa, RHR, stationary, meteo; never Initialize
    reading = tracker.measure()  # one SingleMeasResult, tracker frame, mm

Readings are in the emScon server's current frame (station orientation and
transformation are left as the user set them), in mm; ``rotvec_rad`` is None
(the AT4xx packet set has no 6-DoF probe). emScon results carry no clock, so
``device_time_us`` is the host's monotonic clock when the result arrived.
"""

from __future__ import annotations

import socket
import time
from collections import deque
from dataclasses import dataclass

import numpy as np

from calibrator.acquire import ports
from drivers.errors import DriverError
from drivers.tracker.base import Environment, OpenOptions
from drivers.tracker.emscon import packets as pk
from drivers.tracker.emscon.errors import (
    BeamBroken,
    ConnectionLost,
    FrameError,
    LinkDown,
    ReadingInterrupted,
    TrackerReplaced,
    TrackerTimeout,
)
from drivers.tracker.emscon.link import EmsconLink

DEFAULT_PORT = 700  # emScon's default TCP port


@dataclass(frozen=True)
class EmsconReading:
    """One stationary reading (the ``TrackerReading`` port shape).

    Attributes
    ----------
    point_mm : numpy.ndarray, shape (3,)
        Target position, mm, in the server's frame (normally the tracker frame).
    rotvec_rad : None
        Always None: reflectors only.
    accurate : bool
        False in emScon's try mode or when ``dStdTotal`` exceeds the adapter's limit.
    device_time_us : int
        Host monotonic clock at arrival, us (emScon results carry no time stamp).
    std_mm : numpy.ndarray, shape (4,)
        ``dStd1..3, dStdTotal`` as reported, mm.
    meteo : tuple of float
        Temperature (degC), pressure (hPa), humidity (%) the reading was corrected with.
    """

    point_mm: np.ndarray
    rotvec_rad: None
    accurate: bool
    device_time_us: int
    std_mm: np.ndarray
    meteo: tuple[float, float, float]


@dataclass(frozen=True)
class EmsconStatus:
    """What ``GetSystemStatus`` and ``GetTrackerStatus`` report together."""

    state: pk.TrackerState
    initialised: bool
    serial: int
    version: tuple[int, int, int]


class EmsconTracker:
    """A Leica tracker driven through its emScon server (AT401/402/403, AT901/930 class).

    Parameters
    ----------
    host : str
        Server address (the tracker controller, or 127.0.0.1 for the simulator).
    port : int
        TCP port (emScon's default 700).
    environment : Environment, optional
        Meteo data passed to ``SetEnvironmentParams`` on connect (and after reconnects);
        None leaves the server's (e.g. from a weather station) untouched.
    meas_time_ms : int, optional
        Stationary measurement time (``SetStationaryModeParams``); None leaves it as set.
    max_std_mm : float
        A reading whose ``dStdTotal`` exceeds this is flagged not accurate, mm.
    timeout_s, measure_timeout_s, init_timeout_s, search_timeout_s : float
        Deadlines of ordinary commands, a reading, ``Initialize`` and ``FindReflector``, s.
    search_after_beam_break : bool
        After a beam break, run ``FindReflector`` at the last measured distance
        before reporting :class:`BeamBroken` (the reading is still lost).
    reconnect_attempts : int
        Bounded reconnects after the connection fails (0 disables them).
    reconnect_delay_s : float
        Pause before each reconnect attempt, s.
    """

    capabilities = frozenset({ports.INITIALISE})

    def __init__(
        self,
        host: str,
        port: int = DEFAULT_PORT,
        *,
        environment: Environment | None = None,
        meas_time_ms: int | None = None,
        max_std_mm: float = 0.1,
        timeout_s: float = 2.0,
        measure_timeout_s: float = 10.0,
        init_timeout_s: float = 120.0,
        search_timeout_s: float = 30.0,
        search_after_beam_break: bool = True,
        reconnect_attempts: int = 3,
        reconnect_delay_s: float = 0.2,
    ):
        self.host, self.port = host, int(port)
        self.environment = environment
        self.meas_time_ms = meas_time_ms
        self.max_std_mm = max_std_mm
        self.timeout_s = timeout_s
        self.measure_timeout_s = measure_timeout_s
        self.init_timeout_s = init_timeout_s
        self.search_timeout_s = search_timeout_s
        self.search_after_beam_break = search_after_beam_break
        self.reconnect_attempts = reconnect_attempts
        self.reconnect_delay_s = reconnect_delay_s
        self.events: deque[pk.StatusChangeEvent] = deque(maxlen=256)
        self.serial: int | None = None
        self.last_status: EmsconStatus | None = None
        self.last_distance_mm: float | None = None
        self.searches = 0  # FindReflector runs after beam breaks (diagnostics)
        self._link: EmsconLink | None = None

    # ------------------------------------------------------------ lifecycle

    def connect(self) -> EmsconStatus:
        """Open the connection and apply the settings; return the status.

        Sets units (mm, rad, degC, hPa, %RH, confirmed with ``GetUnits``), the
        right-handed Cartesian frame, stationary mode, optionally the
        stationary time and the environment. Never sends ``Initialize``: that
        moves the head; call :meth:`initialise` when ``initialised`` is False.
        """
        self._open()
        status = self._settle()
        self.serial = status.serial
        return status

    @property
    def device_id(self) -> str:
        """``emscon:serial=N`` of the tracker that answered :meth:`connect` ("" before)."""
        return f"emscon:serial={self.serial}" if self.serial is not None else ""

    def close(self) -> None:
        """Close the connection; safe to call twice or after a failure."""
        if self._link is not None:
            self._link.close()
            self._link = None

    def __enter__(self) -> EmsconTracker:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # ------------------------------------------------------------ commands

    def status(self) -> EmsconStatus:
        """``GetSystemStatus`` + ``GetTrackerStatus``."""
        return self._retrying(lambda link: self._status(link))

    def initialise(self, timeout_s: float | None = None) -> None:
        """``Initialize``: moves the head for tens of seconds. Only ever on the user's request."""
        self._once(pk.Command.INITIALIZE, timeout_s=timeout_s or self.init_timeout_s)

    def find_reflector(self, distance_mm: float, timeout_s: float | None = None) -> None:
        """``FindReflector``: search for a reflector about ``distance_mm`` away along the beam."""
        self._once(
            pk.Command.FIND_REFLECTOR,
            pk.double_param(distance_mm),
            timeout_s=timeout_s or self.search_timeout_s,
        )

    def measure(self, timeout_s: float | None = None) -> EmsconReading:
        """One stationary reading (``StartMeasurement`` -> ``SingleMeasResult``).

        Raises
        ------
        BeamBroken
            No reflector locked; the adapter already ran ``FindReflector`` (when
            enabled and a distance is known). Measure the pose again.
        TargetUnstable, TrackerTimeout, FrameError, ReadingInterrupted
            This reading is lost (all :class:`ReadingLost`); never re-requested here.
        NotInitialised, TrackerBusy, EmsconRefused, UnknownStatus
            The server refused.
        LinkDown
            The connection is gone and could not be re-established.
        """
        timeout_s = timeout_s or self.measure_timeout_s
        try:
            result = self._once(pk.Command.START_MEASUREMENT, timeout_s=timeout_s, measure=True)
        except BeamBroken as exc:
            self._search_after(exc)
            raise
        t_us = time.monotonic_ns() // 1000
        point = np.array(result.values) * self._mm_per_unit
        std = np.array(result.std) * self._mm_per_unit
        self.last_distance_mm = float(np.linalg.norm(point))
        accurate = not result.try_mode and std[3] <= self.max_std_mm
        return EmsconReading(point, None, bool(accurate), t_us, std, tuple(result.meteo))

    # ------------------------------------------------------------ machinery

    _mm_per_unit = pk.LENGTH_UNIT_MM[pk.LU_MILLIMETER]  # connect() enforces mm

    def _search_after(self, exc: BeamBroken) -> None:
        if not self.search_after_beam_break or self.last_distance_mm is None:
            return
        self.searches += 1
        try:
            self.find_reflector(self.last_distance_mm)
            exc.add_note(f"FindReflector at {self.last_distance_mm:.0f} mm re-locked the beam")
        except DriverError as search_exc:  # any failure of the search: the beam stays broken
            exc.add_note(f"FindReflector failed: {search_exc}")

    def _open(self) -> None:
        self.close()
        try:
            sock = socket.create_connection((self.host, self.port), timeout=self.timeout_s)
        except OSError as exc:
            msg = f"cannot connect to emScon at {self.host}:{self.port}: {exc}"
            raise LinkDown(msg) from exc
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._link = EmsconLink(sock, events=self.events)

    def _settle(self) -> EmsconStatus:
        """Apply the settings on a fresh connection and read the status."""
        link = self._link
        t = self.timeout_s
        link.transact(pk.Command.SET_UNITS, pk.units_params(), timeout_s=t)
        units = pk.parse_units(link.transact(pk.Command.GET_UNITS, timeout_s=t).body)
        wanted = pk.parse_units(pk.units_params())
        if units != wanted:  # every value is parsed as mm and rad
            raise FrameError(f"emScon did not confirm units {wanted}: {units}")
        link.transact(pk.Command.SET_COORDINATE_SYSTEM_TYPE, pk.uint_param(pk.CS_RHR), timeout_s=t)
        link.transact(pk.Command.SET_MEASUREMENT_MODE, pk.uint_param(pk.MM_STATIONARY), timeout_s=t)
        if self.meas_time_ms is not None:
            params = pk.stationary_params(self.meas_time_ms, True)
            link.transact(pk.Command.SET_STATIONARY_MODE_PARAMS, params, timeout_s=t)
        if self.environment is not None:
            env = self.environment
            params = pk.env_params(env.temperature_c, env.pressure_hpa, env.humidity_pct)
            link.transact(pk.Command.SET_ENVIRONMENT_PARAMS, params, timeout_s=t)
        return self._status(link)

    def _status(self, link: EmsconLink) -> EmsconStatus:
        sys_reply = link.transact(pk.Command.GET_SYSTEM_STATUS, timeout_s=self.timeout_s)
        system = pk.parse_system_status(sys_reply.body)
        trk_reply = link.transact(pk.Command.GET_TRACKER_STATUS, timeout_s=self.timeout_s)
        code = pk.parse_uint(trk_reply.body)
        try:
            state = pk.TrackerState(code)
        except ValueError:
            raise FrameError(f"GetTrackerStatus returned unknown tracker status {code}") from None
        self.last_status = EmsconStatus(state, system.initialised, system.serial, system.version)
        return self.last_status

    def _usable_link(self) -> EmsconLink:
        if self._link is None or self._link.broken:
            self._reconnect()
        return self._link

    def _once(self, command: int, params: bytes = b"", *, timeout_s: float, measure=False):
        """A command that is never repeated (it moves the head or yields a reading)."""
        link = self._usable_link()
        try:
            return link.transact(command, params, timeout_s=timeout_s, measure=measure)
        except ConnectionLost as exc:
            self._reconnect()  # raises LinkDown when it cannot
            raise ReadingInterrupted(
                f"emScon connection lost during {pk.Command(command).name}; "
                "reconnected, command not repeated"
            ) from exc

    def _retrying(self, operation):
        """An idempotent query: retried once after a broken frame or a reconnect."""
        for attempt in (0, 1):
            link = self._usable_link()
            try:
                return operation(link)
            except TrackerReplaced:
                raise
            except (ConnectionLost, FrameError):
                if attempt:
                    raise
        raise AssertionError("unreachable")

    def _reconnect(self) -> None:
        """Bounded reconnect: reopen, re-apply settings, check the serial. Never initialises."""
        if self.serial is None:
            raise LinkDown("not connected: call connect() first")
        last: Exception | None = None
        for _ in range(self.reconnect_attempts):
            time.sleep(self.reconnect_delay_s)
            try:
                self._open()
                status = self._settle()
            except (ConnectionLost, TrackerTimeout, FrameError) as exc:
                last = exc
                continue
            if status.serial != self.serial:
                self.close()
                raise TrackerReplaced(f"reconnected to serial {status.serial}, not {self.serial}")
            return
        self.close()
        raise LinkDown(
            f"emScon connection lost; {self.reconnect_attempts} reconnect attempts failed: {last}"
        ) from last


def open_tracker(url: str, **options) -> EmsconTracker:
    """An (unconnected) :class:`EmsconTracker` for ``emscon://HOST[:PORT][?meteo=T,P,H]``.

    ``meteo`` gives the environment sent on connect: temperature degC, pressure
    hPa, relative humidity %; without it the server's own values stay. Other
    keyword ``options`` go to :class:`EmsconTracker`.

    Raises
    ------
    ValueError
        Not an ``emscon://`` URL, a bad port, or a bad query.
    """
    from urllib.parse import parse_qs, urlsplit

    parts = urlsplit(url)
    if parts.scheme != "emscon" or not parts.hostname or parts.path not in ("", "/"):
        raise ValueError(f"expected emscon://HOST[:PORT][?meteo=T,P,H], got {url!r}")
    try:
        port = parts.port or DEFAULT_PORT
    except ValueError as exc:
        raise ValueError(f"bad port in {url!r}: {exc}") from None
    query = parse_qs(parts.query, keep_blank_values=True, strict_parsing=bool(parts.query))
    if set(query) - {"meteo"} or any(len(v) != 1 for v in query.values()):
        raise ValueError(f"{url!r}: the only query is meteo=T,P,H (once)")
    if "meteo" in query:
        options["environment"] = _parse_meteo(query["meteo"][0])
    return EmsconTracker(parts.hostname, port, **options)


def open_emscon_tracker(url: str, options: OpenOptions) -> EmsconTracker:
    """The tracker registry's opener for ``emscon://`` (see :mod:`drivers.tracker.base`)."""
    if options.record is not None or options.world is not None:
        raise ValueError(f"{url}: --sim-record and simulator options need a line-protocol tracker")
    return open_tracker(url)


def _parse_meteo(text: str) -> Environment:
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if len(values) != 3 or not all(np.isfinite(values)):
        raise ValueError(f"meteo needs T,P,H (degC, hPa, %RH), got {text!r}")
    return Environment(*values)
