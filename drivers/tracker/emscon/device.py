"""Leica emScon adapter behind the ``Tracker`` port: connect, status, stationary readings.

::

    tracker = EmsconTracker("192.168.0.1", 700, environment=Environment(21.3, 1002.0, 45.0))
    tracker.connect()            # units mm/rad/degC/hPa, RHR, stationary, meteo; never Initialize
    reading = tracker.measure()  # one SingleMeasResult, tracker frame, mm

Readings are in the emScon server's current frame (station orientation and
transformation are left as the user set them), in mm. A reflector gives a
``SingleMeasResult`` (``rotvec_rad`` None); a 6-DoF probe (T-Probe, T-Mac)
gives a ``ProbeStationaryResult``, whose quaternion becomes ``rotvec_rad``
(probe orientation in the server's frame, rad), so a probe can feed 6-DoF
sessions. emScon results carry no clock, so ``device_time_us`` is the host's
monotonic clock when the result arrived.

A result is checked before it is handed out: a non-zero status is the
status's typed error, a non-finite or absurd value (beyond 1 km, a negative
std) is :class:`BadReading`; a try-mode result (emScon's simulation) and one
whose ``dStdTotal`` exceeds ``max_std_mm`` are handed out flagged not accurate,
so the averaging leaves them out.

Capabilities (declared in :data:`CAPABILITIES`, never probed): ``find_reflector``
(:meth:`EmsconTracker.find_reflector`, beam recovery at a predicted point).
"""

from __future__ import annotations

import socket
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from calibrator.acquire import ports
from calibrator.model import rotations
from drivers.errors import DriverError
from drivers.tracker.base import Environment, OpenOptions
from drivers.tracker.emscon import protocol as pk
from drivers.tracker.emscon.errors import (
    BadReading,
    BeamBroken,
    ConnectionLost,
    FrameError,
    IdentityChanged,
    LinkDropped,
    TrackerGone,
    TrackerTimeout,
)
from drivers.tracker.emscon.link import EmsconLink
from drivers.tracker.emscon.reading import EmsconReading
from drivers.tracker.emscon.stream import STALL_TICKS, EmsconReadingStream

DEFAULT_PORT = 700  # emScon's default TCP port
MAX_COORDINATE_MM = 1e6  # 1 km: beyond any tracker's range, so a corrupt value
#: Largest ``dSpatialDistance`` the driver sends, mm (10 m between points).
MAX_SPATIAL_MM = 10_000.0
#: Default silence before a distance-mode stream counts as stalled, s.
DISTANCE_STALL_S = 5.0
MAX_STALLS = 3  # packets cut short in a row (each on a fresh connection): the server is sick
#: What the adapter declares to the acquisition ports: it can initialise the
#: tracker (on request only), search for a lost reflector (FindReflector) and
#: report its environment parameters (GetEnvironmentParams).
CAPABILITIES = frozenset({ports.INITIALISE, ports.SEARCH, ports.REPORTS_CONDITIONS})


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

    capabilities = CAPABILITIES

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
        self._closed = False
        self._stalls = 0  # packets cut short in a row, without a good reading since
        self._streams = 0  # continuous measurements started (stream ids)

    # ------------------------------------------------------------ lifecycle

    def connect(self) -> EmsconStatus:
        """Open the connection and apply the settings; return the status.

        Sets units (mm, rad, degC, hPa, %RH, confirmed with ``GetUnits``), the
        right-handed Cartesian frame, stationary mode, optionally the
        stationary time and the environment. Never sends ``Initialize``: that
        moves the head; call :meth:`initialise` when ``initialised`` is False.
        """
        self._closed = False
        status = self._settle(self._open())
        self.serial = status.serial
        return status

    @property
    def device_id(self) -> str:
        """``emscon:serial=N`` of the tracker that answered :meth:`connect` ("" before)."""
        return f"emscon:serial={self.serial}" if self.serial is not None else ""

    def close(self) -> None:
        """Close the connection; safe to call twice or after a failure.

        Until :meth:`connect` is called again, a command raises :class:`TrackerGone`
        rather than reconnecting (as the line-protocol driver does).
        """
        self._closed = True
        self._drop()

    def _drop(self) -> None:
        """Close the connection, leaving the driver free to reconnect."""
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

    def conditions(self) -> dict:
        """``GetEnvironmentParams``: the air the server corrects its distances for.

        With a meteo station on the tracker these are its readings; emScon
        reports neither the time since power-on nor a warm-up state (it refuses
        a measurement with ``ADM_STARTUP_BUSY`` while warming up).

        Returns
        -------
        dict
            ``air_temperature_c`` (degC), ``air_pressure_hpa`` (hPa),
            ``air_humidity_pct`` (%RH), in the units the adapter set on connect.
        """

        def query(link: EmsconLink) -> tuple[float, float, float]:
            reply = link.transact(pk.Command.GET_ENVIRONMENT_PARAMS, timeout_s=self.timeout_s)
            return pk.parse_env(reply.body)

        t, p, h = self._retrying(query)
        return {"air_temperature_c": t, "air_pressure_hpa": p, "air_humidity_pct": h}

    def initialise(self, timeout_s: float | None = None) -> None:
        """``Initialize``: moves the head for tens of seconds. Only ever on the user's request."""
        self._once(pk.Command.INITIALIZE, timeout_s=timeout_s or self.init_timeout_s)

    def find_reflector(self, predicted_point_mm: ArrayLike, timeout_s: float | None = None) -> None:
        """Re-lock the beam on a reflector expected near ``predicted_point_mm``.

        Points the beam at the prediction (``GoPosition``, without ADM), then
        ``FindReflector`` at its distance: the tracker's own search pattern
        around the beam. Moves the tracker head, never the robot.

        Parameters
        ----------
        predicted_point_mm : array_like, shape (3,)
            Where the reflector should be, mm, in the server's frame (the
            tracker frame unless the user set a transformation).
        timeout_s : float, optional
            Deadline of each of the two commands, s (default ``search_timeout_s``).

        Raises
        ------
        ValueError
            The prediction is not 3 finite coordinates within 1 km.
        BeamBroken
            No reflector found there.
        """
        point = np.asarray(predicted_point_mm, dtype=float).reshape(-1)
        if point.shape != (3,) or not np.all(np.abs(point) <= MAX_COORDINATE_MM):
            raise ValueError(f"predicted point must be 3 finite mm within 1 km, got {point}")
        timeout_s = timeout_s or self.search_timeout_s
        params = pk.go_position_params(point, use_adm=False)  # mm: connect() set the units
        self._once(pk.Command.GO_POSITION, params, timeout_s=timeout_s)
        self._find_at(float(np.linalg.norm(point)), timeout_s)

    def _find_at(self, distance_mm: float, timeout_s: float | None = None) -> None:
        """``FindReflector``: search for a reflector about ``distance_mm`` along the beam."""
        self._once(
            pk.Command.FIND_REFLECTOR,
            pk.double_param(distance_mm),  # mm: connect() set the units
            timeout_s=timeout_s or self.search_timeout_s,
        )

    def measure(self, timeout_s: float | None = None) -> EmsconReading:
        """One stationary reading (``StartMeasurement`` -> ``SingleMeasResult``).

        Raises
        ------
        BeamBroken
            No reflector locked; the adapter already ran ``FindReflector`` (when
            enabled and a distance is known). Measure the pose again.
        TargetUnstable, TrackerTimeout, FrameError, BadReading, LinkDropped
            This reading is lost (all :class:`ReadingLost`); never re-requested here.
        NotInitialised, TrackerBusy, EmsconRefused, UnknownStatus
            The server refused.
        TrackerGone
            The connection is gone and could not be re-established.
        """
        timeout_s = timeout_s or self.measure_timeout_s
        try:
            result = self._once(pk.Command.START_MEASUREMENT, timeout_s=timeout_s, measure=True)
        except BeamBroken as exc:
            self._search_after(exc)
            raise
        t_us = time.monotonic_ns() // 1000
        reading = self._reading(result, t_us)
        self.last_distance_mm = float(np.linalg.norm(reading.point_mm))
        return reading

    def _reading(self, result: pk.MeasResult, t_us: int) -> EmsconReading:
        """Check a result's values and make it a reading (status was checked by the link).

        Values are in mm and rad: connect() set those units and confirmed them.
        """
        point, std, meteo = np.array(result.values), np.array(result.std), np.array(result.meteo)
        rotvec: np.ndarray | None = None
        six_dof_ok = True
        if isinstance(result, pk.ProbeStationaryResult):
            rotvec = rotations.quaternion_to_rotvec(result.quaternion)[0]  # NaN: refused below
            # lRotationStatus bit 0: 6-DoF values valid; bit 1: 6-DoF error.
            six_dof_ok = (result.rotation_status & 0b11) == 0b01
        # NaN compares False, so these refuse it along with inf and absurd values.
        sane = (
            np.all(np.abs(point) <= MAX_COORDINATE_MM)
            and np.all((std >= 0) & (std <= MAX_COORDINATE_MM))
            and np.all(np.isfinite(meteo))
            and (rotvec is None or bool(np.all(np.isfinite(rotvec))))
        )
        if not sane:
            raise BadReading(
                f"emScon result with impossible values: point {point.tolist()} mm, "
                f"std {std.tolist()} mm, meteo {meteo.tolist()}"
                + ("" if rotvec is None else f", orientation {rotvec.tolist()} rad")
            )
        self._stalls = 0
        accurate = not result.try_mode and std[3] <= self.max_std_mm and six_dof_ok
        return EmsconReading(point, rotvec, bool(accurate), t_us, std, tuple(meteo.tolist()))

    # ------------------------------------------------------------ continuous measurement

    def stream(
        self,
        rate_hz: float | None = None,
        count: int | None = None,
        stall_timeout_s: float | None = None,
        *,
        distance_mm: float | None = None,
        six_dof: bool | None = None,
    ) -> EmsconReadingStream:
        """Start a continuous measurement: a point every ``1 / rate_hz`` s (time mode) or
        each time the target has moved ``distance_mm`` (distance mode).

        Sends ``SetMeasurementMode`` (``ES_MM_ContinuousTime`` or
        ``ES_MM_ContinuousDistance``, or their 6-DoF twins ``ES_MM_6DContinuousTime``
        / ``ES_MM_6DContinuousDistance`` for a probe), the mode's parameters
        (``SetContinuousTimeModeParams(lTimeSeparation, lNumberOfPoints)`` or
        ``SetContinuousDistanceModeParams(dSpatialDistance, lNumberOfPoints)``) and
        ``StartMeasurement`` (acknowledged, then results follow). Use the
        returned stream as a context manager: leaving it sends
        ``StopMeasurement`` and sets stationary mode again, so :meth:`measure`
        works as before.

        Parameters
        ----------
        rate_hz : float, optional
            Time mode: requested rate, 1..1000 Hz; the separation sent is the
            nearest whole ms.
        count : int, optional
            Number of points (``lNumberOfPoints``); None streams until stopped.
        stall_timeout_s : float, optional
            Silence after which the stream is stalled, s. Default in time mode 20
            ticks, at least 0.5 s; in distance mode 5 s (a target held still
            sends nothing either: give the longest rest the caller allows).
        distance_mm : float, optional
            Distance mode: the distance the target moves between points, mm
            (0.001..10000); give it instead of ``rate_hz``.
        six_dof : bool, optional
            Stream a 6-DoF probe's orientation too (the 6-DoF mode: each
            reading's ``rotvec_rad``); False streams positions only (a
            reflector's ``rotvec_rad`` is None: absent). None asks the server
            (``GetMeasurementStatusInfo``): 6-DoF when it reports a measurement
            probe (``ES_MSI_MeasurementProbeFound``).

        Raises
        ------
        ValueError
            Neither or both of rate and distance, or either, or count, out of range.
        NotInitialised, BeamBroken, EmsconRefused, TrackerTimeout, ...
            The server refused or did not answer a command (stationary mode is
            set back first when it can be).
        """
        if (rate_hz is None) == (distance_mm is None):
            raise ValueError("give a stream rate_hz (time mode) or distance_mm, not both")
        if rate_hz is not None and not 1.0 <= float(rate_hz) <= 1000.0:
            raise ValueError(f"stream rate {rate_hz} Hz outside 1..1000")
        if distance_mm is not None and not 0.001 <= float(distance_mm) <= MAX_SPATIAL_MM:
            raise ValueError(f"stream distance {distance_mm} mm outside 0.001..{MAX_SPATIAL_MM:g}")
        if count is not None and not 1 <= int(count) <= 2**31 - 1:
            raise ValueError(f"stream count {count} must be a positive 32-bit integer")
        t = self.timeout_s
        if six_dof is None:
            info = self._once(pk.Command.GET_MEASUREMENT_STATUS_INFO, timeout_s=t)
            flags = pk.parse_uint(info.body[4:8])  # lastResultStatus, lMeasurementStatusInfo
            six_dof = bool(flags & pk.MSI_MEASUREMENT_PROBE_FOUND)
        points = 0 if count is None else int(count)
        separation_ms: int | None = None
        if rate_hz is not None:
            separation_ms = max(1, round(1000.0 / float(rate_hz)))
            command = pk.Command.SET_CONTINUOUS_TIME_MODE_PARAMS
            params = pk.continuous_time_params(separation_ms, points)
            default_stall_s = max(STALL_TICKS * separation_ms / 1000.0, 0.5)
        else:
            command = pk.Command.SET_CONTINUOUS_DISTANCE_MODE_PARAMS
            params = pk.continuous_distance_params(float(distance_mm), points)  # type: ignore[arg-type]
            default_stall_s = DISTANCE_STALL_S
        if stall_timeout_s is None:
            stall_timeout_s = default_stall_s
        mode = pk.CONTINUOUS_MODES[(distance_mm is not None, six_dof)]
        self._once(pk.Command.SET_MEASUREMENT_MODE, pk.uint_param(mode), timeout_s=t)
        try:
            self._once(command, params, timeout_s=t)
            self._once(pk.Command.START_MEASUREMENT, timeout_s=t)
        except DriverError:
            self._stationary_again()
            raise
        self._streams += 1
        return EmsconReadingStream(
            self,
            self._streams,
            separation_ms,
            count,
            stall_timeout_s,
            distance_mm=None if distance_mm is None else float(distance_mm),
            six_dof=six_dof,
        )

    def stop_stream(self) -> None:
        """``StopMeasurement`` and stationary mode again (what a stream's ``stop`` sends)."""
        try:
            self._once(pk.Command.STOP_MEASUREMENT, timeout_s=self.timeout_s)
        finally:
            self._stationary_again()

    def _stationary_again(self) -> None:
        mode = pk.uint_param(pk.MM_STATIONARY)
        self._once(pk.Command.SET_MEASUREMENT_MODE, mode, timeout_s=self.timeout_s)

    def stream_link(self) -> EmsconLink:
        """The link a running stream reads (never reconnects: a stream ends with its link)."""
        if self._link is None or self._link.broken:
            raise ConnectionLost("emScon connection lost during continuous measurement")
        return self._link

    def stream_reading(
        self, packet: pk.MultiMeasResult, record: pk.MeasValue, t_us: int
    ) -> EmsconReading | None:
        """A continuous record as a reading, or None when its values are impossible.

        ``MeasValueT`` carries no standard deviation: ``std_mm`` is NaN. The
        reading is flagged not accurate in try mode or when the record's
        ``ES_MeasurementStatus`` is not ``ES_MS_AllOK`` (speed warning, prism
        error, ...): the header says such points "should be treated with care".
        A 6-DoF probe's record (``ProbeMeasValueT``) gives ``rotvec_rad`` from
        its quaternion (a quaternion that is not of unit length is impossible)
        and is flagged not accurate unless its ``lRotationStatus`` says "6-DoF
        valid, no error"; a reflector's reading has ``rotvec_rad`` None.
        """
        point, meteo = np.array(record.values), np.array(packet.meteo)
        if not (np.all(np.abs(point) <= MAX_COORDINATE_MM) and np.all(np.isfinite(meteo))):
            return None
        accurate = not packet.try_mode and record.status == pk.MeasurementStatus.ALL_OK
        rotvec: np.ndarray | None = None
        if record.quaternion is not None:  # a 6-DoF probe's ProbeMeasValueT
            q = np.array(record.quaternion)
            if not (np.all(np.isfinite(q)) and abs(float(np.linalg.norm(q)) - 1.0) < 1e-3):
                return None  # not a rotation: as impossible as a NaN coordinate
            rotvec = rotations.quaternion_to_rotvec(q)[0]
            # lRotationStatus bit 0: 6-DoF values valid; bit 1: 6-DoF error.
            accurate = accurate and (record.rotation_status & 0b11) == 0b01
        std = np.full(4, np.nan)
        return EmsconReading(point, rotvec, bool(accurate), t_us, std, tuple(meteo.tolist()))

    # ------------------------------------------------------------ machinery

    def _search_after(self, exc: BeamBroken) -> None:
        if not self.search_after_beam_break or self.last_distance_mm is None:
            return
        self.searches += 1
        try:
            self._find_at(self.last_distance_mm)
            exc.add_note(f"FindReflector at {self.last_distance_mm:.0f} mm re-locked the beam")
        except DriverError as search_exc:  # any failure of the search: the beam stays broken
            exc.add_note(f"FindReflector failed: {search_exc}")

    def _open(self) -> EmsconLink:
        self._drop()
        try:
            sock = socket.create_connection((self.host, self.port), timeout=self.timeout_s)
        except OSError as exc:
            msg = f"cannot connect to emScon at {self.host}:{self.port}: {exc}"
            raise TrackerGone(msg) from exc
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        # A packet that starts must finish like an ordinary reply: a silence inside it
        # longer than timeout_s is a stall, not a slow measurement.
        self._link = EmsconLink(sock, events=self.events, packet_gap_s=self.timeout_s)
        return self._link

    def _settle(self, link: EmsconLink) -> EmsconStatus:
        """Apply the settings on a fresh connection and read the status."""
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
        if self._closed:
            raise TrackerGone("the emScon driver was closed: call connect() first")
        if self._link is None or self._link.broken:
            return self._reconnect()
        return self._link

    def _once(
        self, command: int, params: bytes = b"", *, timeout_s: float, measure: bool = False
    ) -> Any:
        """A command that is never repeated (it moves the head or yields a reading)."""
        link = self._usable_link()
        try:
            return link.transact(command, params, timeout_s=timeout_s, measure=measure)
        except TrackerTimeout:
            if link.broken:  # a packet stopped half-way: reconnect now, bounded
                self._stalls += 1
                if self._stalls >= MAX_STALLS:
                    self._drop()
                    raise TrackerGone(
                        f"emScon server cut {self._stalls} packets short in a row, "
                        "each on a fresh connection: giving up"
                    ) from None
                self._reconnect()
            raise
        except ConnectionLost as exc:
            self._reconnect()  # raises TrackerGone when it cannot
            raise LinkDropped(
                f"emScon connection lost during {pk.Command(command).name}; "
                "reconnected, command not repeated"
            ) from exc

    def _retrying(self, operation: Callable[[EmsconLink], Any]) -> Any:
        """An idempotent query: retried once after a broken frame or a reconnect."""
        try:
            return operation(self._usable_link())
        except IdentityChanged:
            raise
        except (ConnectionLost, FrameError):
            pass  # once more, on a reconnected link if this one broke
        return operation(self._usable_link())

    def _reconnect(self) -> EmsconLink:
        """Bounded reconnect: reopen, re-apply settings, check the serial. Never initialises."""
        if self.serial is None:
            raise TrackerGone("not connected: call connect() first")
        last: Exception | None = None
        for _ in range(self.reconnect_attempts):
            time.sleep(self.reconnect_delay_s)
            try:
                link = self._open()
                status = self._settle(link)
            except (ConnectionLost, TrackerTimeout, FrameError) as exc:
                last = exc
                continue
            if status.serial != self.serial:
                self._drop()
                raise IdentityChanged(f"reconnected to serial {status.serial}, not {self.serial}")
            return link
        self._drop()
        raise TrackerGone(
            f"emScon connection lost; {self.reconnect_attempts} reconnect attempts failed: {last}"
        ) from last


def open_tracker(url: str, **options: Any) -> EmsconTracker:
    """An (unconnected) :class:`EmsconTracker` for ``emscon://HOST[:PORT][?meteo=T,P,H]``.

    ``meteo`` gives the environment sent on connect: temperature degC, pressure
    hPa, relative humidity %; without it the server's own values stay. Other
    keyword ``options`` go to :class:`EmsconTracker`.

    Raises
    ------
    ValueError
        Not an ``emscon://`` URL, a bad port, or a bad query.
    """
    from drivers import urls

    where = urls.parse(
        url, "emscon", port="optional", default_port=DEFAULT_PORT, params={"meteo": _parse_meteo}
    )
    if "meteo" in where.params:
        options["environment"] = _parse_meteo(where.params["meteo"])
    return EmsconTracker(where.host, where.port or DEFAULT_PORT, **options)


def open_url(url: str, options: OpenOptions) -> EmsconTracker:
    """The tracker registry's opener for ``emscon://`` (see :mod:`drivers.tracker.base`)."""
    if options.record is not None or options.world is not None:
        raise ValueError(
            f"{url}: recording readings (sim://?record=) and simulated-cell settings "
            "need a line-protocol tracker"
        )
    return open_tracker(url)


#: Air a tracker measures in (degC, hPa, %RH): beyond these the refractive
#: index correction is not air's, and a typo (1e308) would pass unseen.
METEO_RANGES = ((-40.0, 60.0), (500.0, 1200.0), (0.0, 100.0))


def _parse_meteo(text: str) -> Environment:
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if len(values) != 3 or not all(np.isfinite(values)):
        raise ValueError(f"meteo needs T,P,H (degC, hPa, %RH), got {text!r:.40}")
    names = ("T degC", "P hPa", "H %RH")
    for value, (low, high), what in zip(values, METEO_RANGES, names, strict=True):
        if not low <= value <= high:
            raise ValueError(f"meteo {what} {value:g} is outside [{low:g}, {high:g}]")
    return Environment(*values)
