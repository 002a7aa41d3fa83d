"""Leica emScon's front-end of the simulated tracker: one received packet in, packets out.

No I/O here (the servers in :mod:`drivers.tracker.emscon.simulator.server`
feed it). The tracker is the line simulator's own
:class:`~drivers.tracker.instrument.Instrument` (target, noise, faults, air,
warm-up, latency); this module decodes emScon commands and encodes its
answers. The fault scripts (:mod:`drivers.tracker.instrument.faults`) count emScon commands
counted under the line protocol's names (``ES_C_StartMeasurement`` is
``MEAS``, ``ES_C_GetTrackerStatus`` is ``STAT?``, see :data:`FAULT_NAMES`),
so ``MEAS@5 beam_break`` means the same on both simulators. How each fault
looks in emScon:

- ``beam_break count=n``: ``ES_SSC_MeasStatus_NotReady`` event, then ``n``
  measurements answered ``ES_RS_MeasurementStatusNotReady``; a
  ``FindReflector`` (or a new target) re-locks, as does the n-th refusal;
- ``unstable count=n``: ``n`` measurements answered ``ES_RS_NoStationaryResult``;
- ``inaccurate count=n``: results whose ``dStdTotal`` is 1 mm;
- ``not_initialised``: the tracker forgets its initialisation;
- ``error code=C``: the line protocol's code mapped to an ``ES_RS_`` status;
- ``drop`` / ``hangup`` / ``delay`` / ``partial``: as on the line simulator,
  applied to the last packet of the answer (the result of a measurement);
- ``garble``: that packet replaced by junk whose size field is impossible;
- ``bad_crc`` (emScon has no checksum): the packet's ``lPacketSize`` is 16,
  disagreeing with its type.

``StartMeasurement`` in stationary mode is answered by its result alone, as
Leica documents it (the acknowledgement before the result is documented for
continuous mode only); ``ack_start=True`` sends an OK reply first, as some
servers do, so clients can be tested against both. A refusal is always a
reply carrying the status. ``probe=True`` simulates a 6-DoF probe: results
are ``ProbeStationaryResult`` packets whose orientation is the target's.
``GoPosition`` aims the beam; ``FindReflector`` then re-locks only if the
target is within :data:`SEARCH_RADIUS_MM` of where the beam points.

Continuous time mode (``ES_MM_ContinuousTime``): ``StartMeasurement`` is
acknowledged, then the server (:mod:`~drivers.tracker.emscon.simulator.server`)
asks :meth:`EmsconSimulator.stream_tick` for one ``MultiMeasResult`` every
``lTimeSeparation`` until ``StopMeasurement``; points show a moving target
(:meth:`EmsconSimulator.set_motion` or ``SIM,PATH``) ``latency_s`` before their
stamp, and the fault scripts' ``SAMPLE`` triggers count ticks. Continuous
distance mode (``ES_MM_ContinuousDistance``) ticks every
:data:`DISTANCE_TICK_S` and sends a point when the target is
``dSpatialDistance`` from the last one sent. With ``probe=True`` the 6-DoF
modes (``ES_MM_6DContinuousTime`` / ``...Distance``) send
``ProbeContinuousResult`` packets carrying the probe's orientation, and
``GetMeasurementStatusInfo`` reports the probe (``ES_MSI_MeasurementProbeFound``).

Warm-up and air: until the instrument is warmed up, ``GetSystemStatus``
reports its laser heating up (``ES_LPS_LaserHeatingUp``), then ready. Given
``air``, a weather station on the tracker reads it: ``GetSystemStatus``
reports the weather monitor reading and calculating refractions, and
``GetEnvironmentParams`` and every result carry the station's air.

The true target is set in-process (:meth:`EmsconSimulator.set_target`) or
over the control port with the line protocol's ``SIM,TARGET`` / ``SIM,NOTARGET``
/ ``SIM,FAULT`` (so ``drivers.tracker.line.simulator.launch.SimulatorControl``
drives it), ``SIM,PATH`` (waypoints, as on the line simulator), plus
``SIM,STATUS,<CMD>,<code>``: answer the next ``<CMD>`` with
an arbitrary result status (e.g. one Leica never defined).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from calibrator.model import rotations
from drivers.tracker.emscon import protocol as pk
from drivers.tracker.emscon.protocol import Command, ResultStatus, StatusChange
from drivers.tracker.errors import FrameError
from drivers.tracker.instrument import (
    MAX_RANGE_MM,
    MIN_RANGE_MM,
    STANDARD_AIR,
    HangUp,
    Instrument,
    Output,
    Send,
    StreamStall,
)
from drivers.tracker.instrument.control import sim_command
from drivers.tracker.instrument.front_end import FrontEnd
from drivers.tracker.instrument.ticks import StreamStart, StreamStop
from drivers.tracker.line.protocol import (
    ErrorCode,
    decode_frame,
    encode_frame,
    error_body,
    ok_body,
    parse_command,
)

METEO_LIMITS = ((-10.0, 50.0), (500.0, 1200.0), (0.0, 100.0))  # degC, hPa, %RH
INACCURATE_STD_MM = 1.0
SEARCH_RADIUS_MM = 100.0  # FindReflector's reach around the aimed point

# emScon commands under the names the shared fault scripts count.
FAULT_NAMES: dict[int, str] = {
    Command.INITIALIZE: "INIT",
    Command.GET_TRACKER_STATUS: "STAT?",
    Command.GET_SYSTEM_STATUS: "SYS?",
    Command.SET_UNITS: "UNITS",
    Command.GET_UNITS: "UNITS?",
    Command.SET_ENVIRONMENT_PARAMS: "ENV",
    Command.GET_ENVIRONMENT_PARAMS: "ENV?",
    Command.SET_MEASUREMENT_MODE: "MODE",
    Command.SET_COORDINATE_SYSTEM_TYPE: "CSYS",
    Command.SET_STATIONARY_MODE_PARAMS: "STATIONARY",
    Command.START_MEASUREMENT: "MEAS",
    Command.STOP_MEASUREMENT: "STOP",
    Command.FIND_REFLECTOR: "FIND",
    Command.GO_POSITION: "GOPOS",
    Command.GET_MEASUREMENT_MODE: "MODE?",
    Command.GET_COORDINATE_SYSTEM_TYPE: "CSYS?",
    Command.GET_MEASUREMENT_STATUS_INFO: "MSI?",
    Command.SET_CONTINUOUS_TIME_MODE_PARAMS: "CONTTIME",
    Command.GET_CONTINUOUS_TIME_MODE_PARAMS: "CONTTIME?",
    Command.SET_CONTINUOUS_DISTANCE_MODE_PARAMS: "CONTDIST",
    Command.GET_CONTINUOUS_DISTANCE_MODE_PARAMS: "CONTDIST?",
}

# Line-protocol error codes (fault scripts) as emScon result statuses.
STATUS_FOR_CODE = {
    ErrorCode.UNKNOWN_COMMAND: ResultStatus.NOT_IMPLEMENTED,
    ErrorCode.BAD_PARAMETER: ResultStatus.WRONG_PARAMETER,
    ErrorCode.BUSY: ResultStatus.SERVER_BUSY,
    ErrorCode.NOT_INITIALISED: ResultStatus.TRACKER_NOT_INITIALIZED,
    ErrorCode.NO_TARGET: ResultStatus.MEASUREMENT_STATUS_NOT_READY,
    ErrorCode.BEAM_BROKEN: ResultStatus.MEASUREMENT_STATUS_NOT_READY,
    ErrorCode.TARGET_UNSTABLE: ResultStatus.NO_STATIONARY_RESULT,
    ErrorCode.OUT_OF_RANGE: ResultStatus.NO_STATIONARY_RESULT,
    ErrorCode.METEO_OUT_OF_RANGE: ResultStatus.METEO_DATA_OUT_OF_RANGE,
    ErrorCode.NOT_WARMED_UP: ResultStatus.ADM_STARTUP_BUSY,
    ErrorCode.BAD_FRAME: ResultStatus.INVALID_INPUT_DATA,
}

#: Longest ``lTimeSeparation`` the simulator takes, ms (a minute between points).
MAX_SEPARATION_MS = 60_000
#: Longest ``dSpatialDistance`` the simulator takes, mm (10 m between points).
MAX_SPATIAL_MM = 10_000.0
#: In distance mode the simulated tracker measures this often on its clock, s, and
#: sends a point when it has moved ``dSpatialDistance`` from the last one sent (an
#: AT9xx measures internally at 1 kHz and more).
DISTANCE_TICK_S = 0.001
#: The continuous modes simulated; the 6-DoF ones with ``probe=True`` only.
TIME_MODES = frozenset({pk.MM_CONTINUOUS_TIME, pk.MM_6D_CONTINUOUS_TIME})
DISTANCE_MODES = frozenset({pk.MM_CONTINUOUS_DISTANCE, pk.MM_6D_CONTINUOUS_DISTANCE})
SIX_DOF_MODES = frozenset({pk.MM_6D_CONTINUOUS_TIME, pk.MM_6D_CONTINUOUS_DISTANCE})


#: What the engine hands its server: packets, hang-ups and stream control.
EmsconOutput = Send | HangUp | StreamStart | StreamStop | StreamStall

# ES_MeasurementStatusInfo bits: tracker, compensation, ADM, ADM compensation found.
_MSI_BASE = 1 | 2 | 4 | 8
_MSI_REFLECTOR, _MSI_INITIALISED = 2048, 65536


class EmsconSimulator(FrontEnd):
    """Leica emScon spoken by a simulated laser tracker (:class:`Instrument`).

    Parameters
    ----------
    air : tuple of 3 float, optional
        The air a weather station on the tracker measures (degC, hPa, %RH):
        the server then corrects with it (``GetSystemStatus`` reports the
        weather monitor reading and calculating refractions;
        ``GetEnvironmentParams`` and every result carry that air, whatever
        ``SetEnvironmentParams`` sent). None (default): no weather station,
        the server corrects with the parameters the client sets.
    serial : int
        ``lTrackerSerialNumber`` of ``GetSystemStatus``.
    ack_start : bool
        Acknowledge ``StartMeasurement`` with an OK reply before the result
        (default False: stationary mode as Leica documents it, result only).
    probe : bool
        Simulate a 6-DoF probe (``ProbeStationaryResult``) instead of a reflector.
    instrument : Instrument, optional
        Speak for this tracker; None builds one from ``tracker`` (and ``air``).
    **tracker
        The tracker's parameters (:class:`~drivers.tracker.instrument.Instrument`:
        ``seed``, ``noise``, ``faults``, ``init_time_s``, ``initialised``,
        ``clock``, ``on_s``, ``latency_s``, ``time_scale``). Until it is warmed up
        (``on_s`` past :data:`~drivers.tracker.instrument.WARM_UP_S`)
        ``GetSystemStatus`` reports its laser heating up.
    """

    def __init__(
        self,
        *,
        air: tuple[float, float, float] | None = None,
        serial: int = 390001,
        ack_start: bool = False,
        probe: bool = False,
        instrument: Instrument | None = None,
        **tracker: Any,
    ):
        super().__init__(instrument, air=STANDARD_AIR if air is None else air, **tracker)
        self.weather_station = air is not None
        self.serial = serial
        self._forced: dict[str, int] = {}
        self.units = pk.parse_units(pk.units_params(length=0, angle=0))  # emScon starts in m
        self._env = (20.0, 1013.25, 50.0)
        self.coordinate_system = pk.CS_RHR
        self.meas_mode = pk.MM_STATIONARY
        self.stationary = (1000, True)  # lMeasTime (ms), bUseADM
        self.ack_start = ack_start
        self.probe = probe
        self.aim_mm: np.ndarray | None = None  # where GoPosition pointed the beam
        self.measurements = 0  # results sent (diagnostics)
        self.continuous_time = (100, 0)  # lTimeSeparation (ms), lNumberOfPoints (0: until stopped)
        self.continuous_distance = (1.0, 0)  # dSpatialDistance (mm), lNumberOfPoints
        # Distance mode's running state: the last point sent (mm) and how many were sent.
        self._last_sent_mm: np.ndarray | None = None
        self._sent = 0
        self.stream_records = 0  # continuous points sent (diagnostics)

    @property
    def env(self) -> tuple[float, ...]:
        """The air the server corrects with: its weather station's, else the client's (degC,
        hPa, %RH)."""
        return self.instrument.air if self.weather_station else self._env

    def force_status(self, name: str, status: int) -> None:
        """Answer the next command counted as ``name`` (e.g. ``"MEAS"``) with ``status``."""
        with self._lock:
            self._forced[name] = int(status)

    # ------------------------------------------------------------ control port (line protocol)

    def handle_line(self, line: bytes) -> list[Output]:
        """A control-port line: the shared ``SIM,...`` commands
        (:func:`~drivers.tracker.instrument.control.sim_command`) and ``SIM,STATUS``."""
        try:
            cmd = parse_command(decode_frame(line))
        except FrameError as exc:
            return [Send(encode_frame(error_body(0, ErrorCode.BAD_FRAME, str(exc))))]
        if cmd.name != "SIM":
            body = error_body(cmd.seq, ErrorCode.UNKNOWN_COMMAND, cmd.name + ",")
        elif cmd.args[:1] == ("STATUS",) and len(cmd.args) == 3:
            try:
                self.force_status(cmd.args[1], int(cmd.args[2]))
                body = ok_body(cmd.seq)
            except ValueError as exc:
                body = error_body(cmd.seq, ErrorCode.BAD_PARAMETER, str(exc))
        else:
            body = sim_command(self.instrument, cmd)
        return [Send(encode_frame(body))]

    # ------------------------------------------------------------ emScon port

    def handle_packet(self, data: bytes) -> list[EmsconOutput]:
        """One complete client packet (``len(data) == lPacketSize``); what to send back."""
        with self._lock:
            try:
                command, params = pk.decode_client_packet(data)
            except ValueError:
                command = pk.parse_uint(data[pk.HEADER.size :]) if len(data) >= 12 else 0
                return [Send(pk.encode_error(command, ResultStatus.INVALID_INPUT_DATA))]
            name = FAULT_NAMES.get(command, "UNKNOWN")
            faults = self.instrument.faults.next_command(name)
            pre: list[bytes] = []
            forced = self._forced.pop(name, None)
            for fault in faults:
                self.instrument.fire(fault)
                if fault.kind == "beam_break":
                    pre.append(pk.encode_status_change(StatusChange.MEAS_STATUS_NOT_READY))
                elif fault.kind == "error":
                    forced = STATUS_FOR_CODE.get(fault.code, ResultStatus.UNKNOWN)
            if forced is not None:
                answer = [pk.encode_reply(command, forced)]
            else:
                answer = self._dispatch(command, params)
            outputs: list[EmsconOutput] = list(self._deliver(pre, answer, faults, command))
            if command == Command.STOP_MEASUREMENT:
                outputs.insert(0, StreamStop())  # no result after the OK reply
            elif command == Command.START_MEASUREMENT and self._starts_stream(answer, forced):
                if self.meas_mode in TIME_MODES:
                    separation_ms, points = self.continuous_time
                    outputs.append(StreamStart(separation_ms / 1000.0, points or None))
                else:  # distance mode: checked every DISTANCE_TICK_S, points counted here
                    self._last_sent_mm, self._sent = None, 0
                    outputs.append(StreamStart(DISTANCE_TICK_S))
            return outputs

    def _starts_stream(self, answer: list[bytes], forced: int | None) -> bool:
        continuous = self.meas_mode in TIME_MODES | DISTANCE_MODES
        return continuous and forced is None and len(answer) == 1 and _ok(answer[0])

    def _deliver(self, pre, answer, faults, command) -> list[Output]:
        """Apply the reply-mangling faults to the last packet of the answer."""
        head = [Send(p) for p in pre + answer[:-1]]
        last = answer[-1]
        init_s = self.instrument.init_time_s
        delay = init_s if command == Command.INITIALIZE and _ok(last) else 0.0
        for fault in faults:
            if fault.kind == "drop":
                return [Send(p) for p in pre]
            if fault.kind == "hangup":
                return [HangUp()]
            if fault.kind == "garble":
                rng = self.instrument.rng
                junk = rng.integers(0, 256, size=len(last), dtype=np.uint8).tobytes()
                last = pk.HEADER.pack(-1, 0xDEAD) + junk[pk.HEADER.size :]
            elif fault.kind == "bad_crc":
                last = pk.HEADER.pack(16, pk.HEADER.unpack_from(last)[1]) + last[8:16]
            elif fault.kind == "delay":
                delay += fault.delay_s
            elif fault.kind == "partial":
                cut = len(last) // 2
                return [*head, Send(last[:cut], delay), Send(last[cut:], fault.delay_s)]
        return [*head, Send(last, delay)]

    def _dispatch(self, command: int, params: bytes) -> list[bytes]:
        try:
            handler = _HANDLERS[Command(command)]
        except (ValueError, KeyError):
            return [pk.encode_reply(command, ResultStatus.NOT_IMPLEMENTED)]
        return handler(self, command, params)

    # ------------------------------------------------------------ commands

    def _ok(self, command, params):
        return [pk.encode_reply(command, ResultStatus.ALL_OK)]

    def _initialize(self, command, params):
        self.initialised = True  # the reply is held back for init_time_s (see _deliver)
        return self._ok(command, params)

    def _system_status(self, command, params):
        processor = pk.ProcessorStatus.INITIALIZED if self.initialised else 4
        # The instrument's warm-up shows as its laser heating up; a weather station as a
        # weather monitor reading the air and calculating the refraction from it.
        warm = self.instrument.warmed_up(self.instrument.clock())
        laser = pk.LaserStatus.READY if warm else pk.LaserStatus.HEATING_UP
        weather = pk.WeatherMonitor.READ_AND_CALCULATE if self.weather_station else 0
        body = pk.system_status_body(processor, self.serial, laser=laser, weather=weather)
        return [pk.encode_reply(command, ResultStatus.ALL_OK, body)]

    def _tracker_status(self, command, params):
        ready = self.initialised and self.instrument.locked_on
        state = pk.TrackerState.READY if ready else pk.TrackerState.NOT_READY
        return [pk.encode_reply(command, ResultStatus.ALL_OK, pk.uint_param(state))]

    def _measurement_status_info(self, command, params):
        flags = _MSI_BASE | (_MSI_REFLECTOR if self.instrument.locked_on else 0)
        flags |= _MSI_INITIALISED if self.initialised else 0
        flags |= pk.MSI_MEASUREMENT_PROBE_FOUND if self.probe else 0
        body = pk.uint_param(0) + pk.uint_param(flags)
        return [pk.encode_reply(command, ResultStatus.ALL_OK, body)]

    def _set_units(self, command, params):
        units = pk.parse_units(params)
        if units[0] not in pk.LENGTH_UNIT_MM or units[1] not in (0, 1, 2):
            return [pk.encode_reply(command, ResultStatus.WRONG_PARAMETER)]
        # Meteo is simulated in degC and hPa (mbar is the same number) only.
        if units[2] != pk.TU_CELSIUS or units[3] not in (0, pk.PU_HPASCAL) or units[4] != pk.HU_RH:
            return [pk.encode_reply(command, ResultStatus.NOT_IMPLEMENTED)]
        self.units = units
        return [*self._ok(command, params), pk.encode_status_change(StatusChange.UNITS_CHANGED)]

    def _get_units(self, command, params):
        return [pk.encode_reply(command, ResultStatus.ALL_OK, pk.units_params(*self.units[:4]))]

    def _set_env(self, command, params):
        env = pk.parse_env(params)
        for value, (lo, hi) in zip(env, METEO_LIMITS, strict=True):
            if not lo <= value <= hi:
                return [pk.encode_reply(command, ResultStatus.METEO_DATA_OUT_OF_RANGE)]
        self._env = env  # a weather station's air replaces it (see env)
        return self._ok(command, params)

    def _get_env(self, command, params):
        body = pk.env_params(*self.env)
        return [pk.encode_reply(command, ResultStatus.ALL_OK, body)]

    def _set_mode(self, command, params):
        mode = pk.parse_uint(params)
        simulated = {pk.MM_STATIONARY} | TIME_MODES | DISTANCE_MODES
        # A 6-DoF mode without a probe: refused (our choice of status; the header says none).
        if mode not in simulated or (mode in SIX_DOF_MODES and not self.probe):
            return [pk.encode_reply(command, ResultStatus.NOT_IMPLEMENTED)]
        self.meas_mode = mode
        return self._ok(command, params)

    def _set_continuous_time(self, command, params):
        separation_ms, points = pk.parse_continuous_time(params)
        if not 1 <= separation_ms <= MAX_SEPARATION_MS or points < 0:
            return [pk.encode_reply(command, ResultStatus.WRONG_PARAMETER)]
        self.continuous_time = (separation_ms, points)
        return self._ok(command, params)

    def _get_continuous_time(self, command, params):
        body = pk.continuous_time_params(*self.continuous_time)
        return [pk.encode_reply(command, ResultStatus.ALL_OK, body)]

    def _set_continuous_distance(self, command, params):
        distance, points = pk.parse_continuous_distance(params)
        distance_mm = distance * pk.LENGTH_UNIT_MM[self.units[0]]  # in the length unit set
        if not (np.isfinite(distance_mm) and 0.0 < distance_mm <= MAX_SPATIAL_MM) or points < 0:
            return [pk.encode_reply(command, ResultStatus.WRONG_PARAMETER)]
        self.continuous_distance = (float(distance_mm), points)
        return self._ok(command, params)

    def _get_continuous_distance(self, command, params):
        distance_mm, points = self.continuous_distance
        body = pk.continuous_distance_params(distance_mm / pk.LENGTH_UNIT_MM[self.units[0]], points)
        return [pk.encode_reply(command, ResultStatus.ALL_OK, body)]

    def _set_stationary(self, command, params):
        meas_time_ms, use_adm = pk.parse_stationary(params)
        if meas_time_ms <= 0:
            return [pk.encode_reply(command, ResultStatus.WRONG_PARAMETER)]
        self.stationary = (meas_time_ms, use_adm)
        return self._ok(command, params)

    def _get_mode(self, command, params):
        return [pk.encode_reply(command, ResultStatus.ALL_OK, pk.uint_param(self.meas_mode))]

    def _get_coordinates(self, command, params):
        body = pk.uint_param(self.coordinate_system)
        return [pk.encode_reply(command, ResultStatus.ALL_OK, body)]

    def _go_position(self, command, params):
        if not self.initialised:
            return [pk.encode_reply(command, ResultStatus.TRACKER_NOT_INITIALIZED)]
        point, _ = pk.parse_go_position(params)
        aim = np.array(point) * pk.LENGTH_UNIT_MM[self.units[0]]
        if not np.all(np.isfinite(aim)) or not 0 < np.linalg.norm(aim) <= MAX_RANGE_MM:
            return [pk.encode_reply(command, ResultStatus.WRONG_PARAMETER)]
        self.aim_mm = aim
        return self._ok(command, params)

    def _set_coordinates(self, command, params):
        if pk.parse_uint(params) != pk.CS_RHR:  # only the Cartesian frame is simulated
            return [pk.encode_reply(command, ResultStatus.NOT_IMPLEMENTED)]
        if self.coordinate_system == pk.CS_RHR:
            return self._ok(command, params)  # unchanged: nothing to announce
        self.coordinate_system = pk.CS_RHR
        change = pk.encode_status_change(StatusChange.COORDINATE_SYSTEM_TYPE_CHANGED)
        return [*self._ok(command, params), change]

    def _find_reflector(self, command, params):
        if not self.initialised:
            return [pk.encode_reply(command, ResultStatus.TRACKER_NOT_INITIALIZED)]
        target = self.instrument.target
        if target is None:
            return [pk.encode_reply(command, ResultStatus.MEASUREMENT_STATUS_NOT_READY)]
        aim, self.aim_mm = self.aim_mm, None
        if aim is not None and np.linalg.norm(target - aim) > SEARCH_RADIUS_MM:
            return [pk.encode_reply(command, ResultStatus.MEASUREMENT_STATUS_NOT_READY)]
        self.instrument.beam_broken_left = 0
        ready = pk.encode_status_change(StatusChange.MEAS_STATUS_READY)
        return [ready, *self._ok(command, params)]

    def _start_measurement(self, command, params):
        inst = self.instrument
        refuse = None
        if not inst.initialised:
            refuse = ResultStatus.TRACKER_NOT_INITIALIZED
        elif inst.target is None:
            refuse = ResultStatus.MEASUREMENT_STATUS_NOT_READY
        elif inst.beam_broken_left:
            refuse = ResultStatus.MEASUREMENT_STATUS_NOT_READY
            if inst.take_broken_reading()[1]:  # the tracker re-locks on its own afterwards
                ready = pk.encode_status_change(StatusChange.MEAS_STATUS_READY)
                return [pk.encode_reply(command, refuse), ready]
        elif self.meas_mode in TIME_MODES | DISTANCE_MODES:
            # Continuous mode is acknowledged, then results follow (StreamStart, above).
            return [pk.encode_reply(command, ResultStatus.ALL_OK)]
        elif not MIN_RANGE_MM <= inst.range_mm <= MAX_RANGE_MM:
            refuse = ResultStatus.NO_STATIONARY_RESULT
        elif inst.take_unstable():
            refuse = ResultStatus.NO_STATIONARY_RESULT
        if refuse is not None:
            return [pk.encode_reply(command, refuse)]
        # A moving target: where it is now, less the latency.
        target, rotvec, scale = inst.pose_at(inst.device_time_s())
        if scale is None:
            scale = inst.noise.scale_matrix(target)
        point = inst.sample_point(target, scale)
        if inst.noise.enabled:
            std_xyz = np.sqrt(np.sum(scale**2, axis=0))
        else:
            std_xyz = np.zeros(3)
        total = float(np.linalg.norm(std_xyz))
        if inst.take_inaccurate():
            total = INACCURATE_STD_MM
        per_unit = pk.LENGTH_UNIT_MM[self.units[0]]
        std = (*(std_xyz / per_unit), total / per_unit)
        if self.probe:
            w, x, y, z = rotations.rotvec_to_quaternion(inst.sample_rotvec(rotvec))[0]
            quaternion = (float(w), float(x), float(y), float(z))
            result = pk.encode_probe_stationary_result(point / per_unit, std, quaternion, self.env)
        else:
            result = pk.encode_single_meas_result(point / per_unit, std, self.env)
        self.measurements += 1
        if self.ack_start:
            return [pk.encode_reply(command, ResultStatus.ALL_OK), result]
        return [result]

    # ------------------------------------------------------------ continuous results

    def stream_tick(self, n: int, stamp_s: float) -> list[EmsconOutput]:
        """Outputs of tick ``n`` of a continuous measurement, due at ``stamp_s`` (device s).

        The point is taken and stamped at its due time on the tracker's clock
        (a server running late sends it late, never with a later position), at
        the target's position ``latency_s`` before the stamp. In time mode
        every tick sends a point; in distance mode the ticks are the tracker's
        own checks (every :data:`DISTANCE_TICK_S`) and a point is sent only
        when the measured position is ``dSpatialDistance`` or more from the
        last one sent (the first at once), until ``lNumberOfPoints``. In a
        6-DoF mode the record is a ``ProbeMeasValueT`` with the probe's
        orientation. The fault script's ``SAMPLE`` triggers count ticks:
        ``beam_break count=k`` sends ``ES_SSC_MeasStatus_NotReady`` and
        ``ES_DT_Error`` (``ES_RS_MeasurementStatusNotReady``) once, then
        nothing for ``k`` ticks, then ``ES_SSC_MeasStatus_Ready``; ``stall
        delay=s`` silences the stream for ``s`` (the ticks due meanwhile are
        lost); ``drop`` loses this tick; ``hangup`` closes the connection;
        ``inaccurate`` flags points ``ES_MS_SpeedWarning``.
        """
        with self._lock:
            t_us = max(int(round(stamp_s * 1e6)), 0)
            inst = self.instrument
            faults = inst.faults.next_command("SAMPLE", count_any=False)
            out: list[EmsconOutput] = []
            for fault in faults:
                if fault.kind == "stall":
                    return [StreamStall(fault.delay_s)]
                if fault.kind == "drop":
                    return []
                if fault.kind == "hangup":
                    return [HangUp()]
                if fault.kind in ("beam_break", "inaccurate"):
                    inst.fire(fault)
                if fault.kind == "beam_break":
                    out.append(Send(pk.encode_status_change(StatusChange.MEAS_STATUS_NOT_READY)))
                    not_ready = ResultStatus.MEASUREMENT_STATUS_NOT_READY
                    out.append(Send(pk.encode_error(Command.START_MEASUREMENT, not_ready)))
            if inst.target is None:
                return out  # nothing to follow: no points (the client's stall timer runs)
            refused, restored = inst.take_broken_reading()
            if refused:
                if restored:  # re-locked after this tick
                    out.append(Send(pk.encode_status_change(StatusChange.MEAS_STATUS_READY)))
                return out
            point, rotvec, scale = inst.pose_at(t_us / 1e6)
            if not inst.in_range(point):
                return out  # out of range: no point at this tick
            point = inst.sample_point(point, scale)
            distance_mode = self.meas_mode in DISTANCE_MODES
            if distance_mode and self._last_sent_mm is not None:
                moved = float(np.linalg.norm(point - self._last_sent_mm))
                if moved < self.continuous_distance[0]:
                    return out  # not far enough from the last point sent
            status = pk.MeasurementStatus.ALL_OK
            if inst.take_inaccurate():
                status = pk.MeasurementStatus.SPEED_WARNING
            per_unit = pk.LENGTH_UNIT_MM[self.units[0]]
            xyz = tuple(point / per_unit)
            if self.meas_mode in SIX_DOF_MODES:
                w, x, y, z = rotations.rotvec_to_quaternion(inst.sample_rotvec(rotvec))[0]
                quaternion = (float(w), float(x), float(y), float(z))
                packet = pk.encode_probe_continuous_result(
                    [(int(status), t_us, xyz, quaternion)], self.env, meas_mode=self.meas_mode
                )
            else:
                packet = pk.encode_multi_meas_result(
                    [(int(status), t_us, xyz)], self.env, meas_mode=self.meas_mode
                )
            out.append(Send(packet))
            self.stream_records += 1
            if distance_mode:
                self._last_sent_mm, self._sent = point, self._sent + 1
                if self._sent == self.continuous_distance[1]:
                    out.append(StreamStop())  # lNumberOfPoints sent: the measurement is over
            return out


def _ok(packet: bytes) -> bool:
    return len(packet) >= 16 and pk.parse_uint(packet[12:16]) == ResultStatus.ALL_OK


_HANDLERS = {
    Command.INITIALIZE: EmsconSimulator._initialize,
    Command.GET_SYSTEM_STATUS: EmsconSimulator._system_status,
    Command.GET_TRACKER_STATUS: EmsconSimulator._tracker_status,
    Command.GET_MEASUREMENT_STATUS_INFO: EmsconSimulator._measurement_status_info,
    Command.SET_UNITS: EmsconSimulator._set_units,
    Command.GET_UNITS: EmsconSimulator._get_units,
    Command.SET_ENVIRONMENT_PARAMS: EmsconSimulator._set_env,
    Command.GET_ENVIRONMENT_PARAMS: EmsconSimulator._get_env,
    Command.SET_MEASUREMENT_MODE: EmsconSimulator._set_mode,
    Command.SET_COORDINATE_SYSTEM_TYPE: EmsconSimulator._set_coordinates,
    Command.SET_STATIONARY_MODE_PARAMS: EmsconSimulator._set_stationary,
    Command.START_MEASUREMENT: EmsconSimulator._start_measurement,
    Command.SET_CONTINUOUS_TIME_MODE_PARAMS: EmsconSimulator._set_continuous_time,
    Command.GET_CONTINUOUS_TIME_MODE_PARAMS: EmsconSimulator._get_continuous_time,
    Command.SET_CONTINUOUS_DISTANCE_MODE_PARAMS: EmsconSimulator._set_continuous_distance,
    Command.GET_CONTINUOUS_DISTANCE_MODE_PARAMS: EmsconSimulator._get_continuous_distance,
    Command.STOP_MEASUREMENT: EmsconSimulator._ok,
    Command.FIND_REFLECTOR: EmsconSimulator._find_reflector,
    Command.GO_POSITION: EmsconSimulator._go_position,
    Command.GET_MEASUREMENT_MODE: EmsconSimulator._get_mode,
    Command.GET_COORDINATE_SYSTEM_TYPE: EmsconSimulator._get_coordinates,
}
