"""Leica emScon TCP packets: the subset the adapter and simulator use, written with ``struct``.

Layouts follow Leica's published C API header (``ES_C_API_Def.h``, TPI/SDK
V3.6: the AT4xx extract, and the full header for the multi-measurement and
6-DoF probe results, types 3, 4, 5, 10 and 11). That header sets
``#pragma pack(4)``: every field is a 4-byte integer/enum or an 8-byte double,
so with 4-byte packing there is no padding anywhere and the little-endian
``struct`` formats below (``<``, no alignment) reproduce the C layout byte for byte.

Every packet starts with the 8-byte header ``int32 lPacketSize; uint32 type``
(``lPacketSize`` counts the whole packet, header included). Commands carry
``uint32 command`` next; command replies carry ``uint32 command; uint32 status``
(``ES_ResultStatus``); result packets carry ``uint32 status`` then their data.
"""

from __future__ import annotations

import enum
import struct
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

HEADER = struct.Struct("<iI")  # lPacketSize, type
# Fixed-size packets are checked against their layout; a multi-measurement result
# (continuous mode) has no fixed size: lNumberOfResults records follow its head.
# Bound it where no real server goes: 4 MiB is ~20,000 6-DoF records, seconds of
# continuous data at the fastest rate, and far below what would starve the host.
MAX_PACKET = 4 * 1024 * 1024
MAX_FIXED_PACKET = 4096  # every fixed layout is far smaller (the largest is 376 bytes)


class DataType(enum.IntEnum):
    """``ES_DataType``: the second header field."""

    COMMAND = 0
    ERROR = 1
    SINGLE_MEAS_RESULT = 2
    MULTI_MEAS_RESULT = 3
    STATIONARY_PROBE_MEAS_RESULT = 4
    CONTINUOUS_PROBE_MEAS_RESULT = 5
    NIVEL_RESULT = 6
    REFLECTOR_POS_RESULT = 7
    SYSTEM_STATUS_CHANGE = 8
    SINGLE_MEAS_RESULT2 = 9
    MULTI_MEAS_RESULT2 = 10
    PROBE_POS_RESULT = 11


class Command(enum.IntEnum):
    """``ES_Command`` values of the commands this package sends or simulates."""

    EXIT_APPLICATION = 0
    GET_SYSTEM_STATUS = 1
    GET_TRACKER_STATUS = 2
    SET_UNITS = 5
    GET_UNITS = 6
    INITIALIZE = 7
    SET_ENVIRONMENT_PARAMS = 20
    GET_ENVIRONMENT_PARAMS = 21
    SET_MEASUREMENT_MODE = 24
    GET_MEASUREMENT_MODE = 25
    SET_COORDINATE_SYSTEM_TYPE = 26
    GET_COORDINATE_SYSTEM_TYPE = 27
    SET_STATIONARY_MODE_PARAMS = 28
    SET_CONTINUOUS_TIME_MODE_PARAMS = 30
    GET_CONTINUOUS_TIME_MODE_PARAMS = 31
    SET_CONTINUOUS_DISTANCE_MODE_PARAMS = 32
    GET_CONTINUOUS_DISTANCE_MODE_PARAMS = 33
    START_MEASUREMENT = 49
    STOP_MEASUREMENT = 52
    GO_POSITION = 55
    FIND_REFLECTOR = 63
    GET_MEASUREMENT_STATUS_INFO = 122


class ResultStatus(enum.IntEnum):
    """``ES_ResultStatus`` values the adapter distinguishes (others keep their number)."""

    ALL_OK = 0
    SERVER_BUSY = 1
    NOT_IMPLEMENTED = 2
    WRONG_PARAMETER = 3
    UNKNOWN = 36
    NO_TRACKER_CONNECTED = 38
    TRACKER_NOT_INITIALIZED = 39
    MODULE_TIMED_OUT = 41
    METEO_DATA_OUT_OF_RANGE = 57
    INVALID_INPUT_DATA = 98
    MEASUREMENT_STATUS_NOT_READY = 10004
    ADM_STARTUP_BUSY = 10005
    NO_STATIONARY_RESULT = 10009
    SENSOR_NOT_LEVELED = 10010
    MULTI_CONNECTIONS_NOT_ALLOWED = 10011
    SENSOR_NOT_STABLE = 10013
    SYSTEM_NOT_READY_FOR_MEASUREMENT = 10014
    COMMUNICATION_WITH_SENSOR_FAILED = 10015


# Every ES_ResultStatus value of the V3.6 header: a code outside this set is "unknown".
KNOWN_STATUS = frozenset(
    [*range(0, 24), *range(26, 33), 35, 36, 37, 38, 39, 40, 41, 44, *range(47, 58)]
    + [90, 94, 95, 96, 98, 10002, 10003, 10004, 10005, 10007, 10008, 10009, 10010, 10011]
    + [*range(10013, 10022)]
)


class TrackerState(enum.IntEnum):
    """``ES_TrackerStatus`` (``GetTrackerStatus``)."""

    NOT_READY = 0
    BUSY = 1
    READY = 2


class ProcessorStatus(enum.IntEnum):
    """``ES_TrackerProcessorStatus`` (``GetSystemStatus``): initialised is the last stage."""

    NO_TP_FOUND = 0
    TP_FOUND = 1
    BOOTED = 3
    COMPENSATION_SET = 4
    INITIALIZED = 5


class LaserStatus(enum.IntEnum):
    """``ES_LaserProcessorStatus`` (``GetSystemStatus``), the values the simulator sends."""

    HEATING_UP = 2
    READY = 3


class WeatherMonitor(enum.IntEnum):
    """``ES_WeatherMonitorStatus`` (``GetSystemStatus``)."""

    NOT_CONNECTED = 0
    READ_ONLY = 1
    READ_AND_CALCULATE = 2  # reads the air and corrects distances with it


class StatusChange(enum.IntEnum):
    """``ES_SystemStatusChange`` events the adapter acts on."""

    UNITS_CHANGED = 6
    COORDINATE_SYSTEM_TYPE_CHANGED = 12
    MEAS_STATUS_NOT_READY = 25
    MEAS_STATUS_BUSY = 26
    MEAS_STATUS_READY = 27
    SERVER_CLOSING = 998


# ES_LengthUnit / ES_AngleUnit / ES_TemperatureUnit / ES_PressureUnit / ES_HumidityUnit
LU_MILLIMETER = 1
AU_RADIAN = 0
TU_CELSIUS = 0
PU_HPASCAL = 1
HU_RH = 0
CS_RHR = 0  # ES_CoordinateSystemType: right-handed Cartesian
MM_STATIONARY = 0  # ES_MeasMode
MM_CONTINUOUS_TIME = 1  # ES_MM_ContinuousTime: one point every lTimeSeparation ms
MM_CONTINUOUS_DISTANCE = 2  # ES_MM_ContinuousDistance: one point every dSpatialDistance
MM_6D_CONTINUOUS_TIME = 7  # ES_MM_6DContinuousTime: a probe's pose every lTimeSeparation ms
MM_6D_CONTINUOUS_DISTANCE = 8  # ES_MM_6DContinuousDistance: a probe's pose every dSpatialDistance
#: The continuous modes, by (distance?, 6-DoF?).
CONTINUOUS_MODES = {
    (False, False): MM_CONTINUOUS_TIME,
    (True, False): MM_CONTINUOUS_DISTANCE,
    (False, True): MM_6D_CONTINUOUS_TIME,
    (True, True): MM_6D_CONTINUOUS_DISTANCE,
}
MSI_MEASUREMENT_PROBE_FOUND = 128  # ES_MeasurementStatusInfo: a 6-DoF probe is connected
RT_SPHERE = 0  # ES_RegionType (only sent with bUseRegion false: no region)
LENGTH_UNIT_MM = {0: 1000.0, 1: 1.0, 2: 0.001, 3: 304.8, 4: 914.4, 5: 25.4}  # mm per unit

# Body formats after the header (and after ``command`` for commands).
_UNITS = struct.Struct("<5I")
_ENV = struct.Struct("<3d")
_RESULT = struct.Struct("<Ii17d")  # measMode, bIsTryMode, dVal1..dHumidity
_RESULT2 = struct.Struct("<Ii23d")  # the same with covariances (statistic mode "extended")
# ProbeStationaryResultT: measMode, bIsTryMode, triggerStatus, lRotationStatus,
# iInternalProbeId, iFieldNumber, tipStatus, iInternalTipAdapterId,
# iTipAdapterInterface, then 41 doubles: position (3), its std (3 + total),
# covariances (3), a-priori std (4) and covariances (3); quaternion (4), rotation
# angles (3), their std (3 + total), covariances (3), a-priori std (4) and
# covariances (3); temperature, pressure, humidity. ``long`` is 4 bytes (LLP64).
_PROBE = struct.Struct("<IiIiiiIii41d")
_SYSTEM_STATUS = struct.Struct("<4I3iIii")
_CMD = struct.Struct("<I")
# ContinuousTimeModeDataT: lTimeSeparation (ms), lNumberOfPoints (0: until stopped),
# bUseRegion, regionType. ContinuousDistanceModeDataT: dSpatialDistance (length unit),
# lNumberOfPoints, bUseRegion, regionType.
_CONT_TIME = struct.Struct("<iiiI")
_CONT_DIST = struct.Struct("<diiI")
# MultiMeasResultT after ReturnDataT: lNumberOfResults, measMode, bIsTryMode,
# dTemperature, dPressure, dHumidity; then MeasValueT records: status
# (ES_MeasurementStatus), lTime1, lTime2, dVal1..3.
_MULTI_HEAD = struct.Struct("<iIi3d")
_MEAS_VALUE = struct.Struct("<Iii3d")
# ProbeContinuousResultT after ReturnDataT: lNumberOfResults, measMode, bIsTryMode,
# iInternalProbeId, iFieldNumber, tipStatus, iInternalTipAdapterId,
# iTipAdapterInterface, then temperature, pressure, humidity; then ProbeMeasValueT
# records: status, triggerStatus, lRotationStatus, lTime1, lTime2, then 24 doubles:
# position (3), its std (3 + total), covariances (3), quaternion (4), rotation
# angles (3), their std (3 + total), covariances (3).
_PROBE_MULTI_HEAD = struct.Struct("<iIiiiIii3d")
_PROBE_MEAS_VALUE = struct.Struct("<IIiii24d")
_CMD_REPLY = struct.Struct("<II")

# Full sizes in bytes, from the layouts (header included).
SIZE_COMMAND = 12
SIZE_COMMAND_REPLY = 16
SIZE_ERROR = 16
SIZE_STATUS_CHANGE = 12
SIZE_SINGLE_MEAS_RESULT = 12 + _RESULT.size  # 156
SIZE_SINGLE_MEAS_RESULT2 = 12 + _RESULT2.size  # 204
SIZE_NIVEL_RESULT = 40
SIZE_REFLECTOR_POS_RESULT = 36
SIZE_PROBE_STATIONARY_RESULT = 12 + _PROBE.size  # 376
SIZE_PROBE_POS_RESULT = 12 + 4 * 4 + 10 * 8  # 108

FIXED_SIZES = {
    DataType.ERROR: SIZE_ERROR,
    DataType.SINGLE_MEAS_RESULT: SIZE_SINGLE_MEAS_RESULT,
    DataType.NIVEL_RESULT: SIZE_NIVEL_RESULT,
    DataType.REFLECTOR_POS_RESULT: SIZE_REFLECTOR_POS_RESULT,
    DataType.SYSTEM_STATUS_CHANGE: SIZE_STATUS_CHANGE,
    DataType.SINGLE_MEAS_RESULT2: SIZE_SINGLE_MEAS_RESULT2,
    DataType.STATIONARY_PROBE_MEAS_RESULT: SIZE_PROBE_STATIONARY_RESULT,
    DataType.PROBE_POS_RESULT: SIZE_PROBE_POS_RESULT,
}

# Multi-measurement results: (size of the head, size of one record), header included.
# Head: ReturnDataT, lNumberOfResults, measMode, bIsTryMode[, probe id, field, tip
# status, tip adapter id and interface], temperature, pressure, humidity.
# Records: MeasValueT (3 ints, 3 doubles), MeasValue2T (3 ints, 10 doubles),
# ProbeMeasValueT (5 ints, 24 doubles).
VARIABLE_SIZES = {
    DataType.MULTI_MEAS_RESULT: (12 + 3 * 4 + 3 * 8, 3 * 4 + 3 * 8),
    DataType.MULTI_MEAS_RESULT2: (12 + 3 * 4 + 3 * 8, 3 * 4 + 10 * 8),
    DataType.CONTINUOUS_PROBE_MEAS_RESULT: (12 + 8 * 4 + 3 * 8, 5 * 4 + 24 * 8),
}

# Size of each command packet (client to server) by command, header included.
COMMAND_SIZES: dict[int, int] = {
    Command.SET_UNITS: SIZE_COMMAND + _UNITS.size,
    Command.SET_ENVIRONMENT_PARAMS: SIZE_COMMAND + _ENV.size,
    Command.SET_MEASUREMENT_MODE: SIZE_COMMAND + 4,
    Command.SET_COORDINATE_SYSTEM_TYPE: SIZE_COMMAND + 4,
    Command.SET_STATIONARY_MODE_PARAMS: SIZE_COMMAND + 8,
    Command.FIND_REFLECTOR: SIZE_COMMAND + 8,
    Command.GO_POSITION: SIZE_COMMAND + 28,
    Command.SET_CONTINUOUS_TIME_MODE_PARAMS: SIZE_COMMAND + _CONT_TIME.size,
    Command.SET_CONTINUOUS_DISTANCE_MODE_PARAMS: SIZE_COMMAND + _CONT_DIST.size,
}

# Size of each command reply (server to client) by command; others are 16.
REPLY_SIZES: dict[int, int] = {
    Command.GET_SYSTEM_STATUS: SIZE_COMMAND_REPLY + _SYSTEM_STATUS.size,  # 56
    Command.GET_TRACKER_STATUS: SIZE_COMMAND_REPLY + 4,
    Command.GET_UNITS: SIZE_COMMAND_REPLY + _UNITS.size,
    Command.GET_ENVIRONMENT_PARAMS: SIZE_COMMAND_REPLY + _ENV.size,
    Command.GET_MEASUREMENT_MODE: SIZE_COMMAND_REPLY + 4,
    Command.GET_COORDINATE_SYSTEM_TYPE: SIZE_COMMAND_REPLY + 4,
    Command.GET_MEASUREMENT_STATUS_INFO: SIZE_COMMAND_REPLY + 8,
    Command.GET_CONTINUOUS_TIME_MODE_PARAMS: SIZE_COMMAND_REPLY + _CONT_TIME.size,
    Command.GET_CONTINUOUS_DISTANCE_MODE_PARAMS: SIZE_COMMAND_REPLY + _CONT_DIST.size,
}


def command_size(command: int) -> int:
    """Size of a command packet, header included (12 for commands without parameters)."""
    return COMMAND_SIZES.get(command, SIZE_COMMAND)


def reply_size(command: int) -> int:
    """Size of the server's reply to ``command``, header included."""
    return REPLY_SIZES.get(command, SIZE_COMMAND_REPLY)


class PacketSizeError(ValueError):
    """A packet's ``lPacketSize`` disagrees with its type (or is out of bounds)."""


# ---------------------------------------------------------------- packets as values


@dataclass(frozen=True)
class CommandReply:
    """``ES_DT_Command`` from the server: the answer to one command.

    ``body`` holds the bytes after ``command`` and ``status`` (parsed by the caller).
    """

    command: int
    status: int
    body: bytes


@dataclass(frozen=True)
class ErrorResponse:
    """``ES_DT_Error``: the server refused ``command`` with ``status``."""

    command: int
    status: int


@dataclass(frozen=True)
class SingleMeasResult:
    """``ES_DT_SingleMeasResult`` (or ``SingleMeasResult2``): one stationary reading.

    Attributes
    ----------
    status : int
        ``ES_ResultStatus`` of the measurement.
    try_mode : bool
        ``bIsTryMode``: a simulated reading of emScon's own try mode.
    values : tuple of float
        ``dVal1..3``: X, Y, Z in the length unit set (Cartesian RHR).
    std : tuple of float
        ``dStd1..3`` and ``dStdTotal``, length unit.
    meteo : tuple of float
        ``dTemperature, dPressure, dHumidity`` used for the reading.
    """

    status: int
    meas_mode: int
    try_mode: bool
    values: tuple[float, float, float]
    std: tuple[float, float, float, float]
    meteo: tuple[float, float, float]


@dataclass(frozen=True)
class ProbeStationaryResult:
    """``ES_DT_StationaryProbeMeasResult``: one stationary 6-DoF probe reading.

    Attributes
    ----------
    status, meas_mode, try_mode
        As in :class:`SingleMeasResult`.
    values : tuple of float
        ``dPosition1..3``: the probe tip, length unit.
    std : tuple of float
        ``dStdDevPosition1..3, dStdDevPositionTotal``, length unit.
    quaternion : tuple of float
        ``dQuaternion0..3``, scalar first: the probe's orientation in the server's frame.
    rotation_std : tuple of float
        ``dStdDevRotationAngleX..Z, dStdDevRotationAngleTotal``, angle unit.
    meteo : tuple of float
        ``dTemperature, dPressure, dHumidity`` used for the reading.
    rotation_status : int
        ``lRotationStatus`` bit field (bit 0: 6-DoF valid, bit 1: 6-DoF error).
    """

    status: int
    meas_mode: int
    try_mode: bool
    values: tuple[float, float, float]
    std: tuple[float, float, float, float]
    quaternion: tuple[float, float, float, float]
    rotation_std: tuple[float, float, float, float]
    meteo: tuple[float, float, float]
    rotation_status: int


class MeasurementStatus(enum.IntEnum):
    """``ES_MeasurementStatus``: the status of one record of a continuous stream."""

    ALL_OK = 0
    SPEED_WARNING = 1
    SPEED_EXCEEDED = 2
    PRISM_ERROR = 3
    TRIGGER_TIME_VIOLATION = 4


@dataclass(frozen=True)
class MeasValue:
    """``MeasValueT``: one point of a continuous stream.

    Attributes
    ----------
    status : int
        ``ES_MeasurementStatus`` (0 all OK; others "should be treated with care").
    time1, time2 : int
        ``lTime1``, ``lTime2``: the record's time stamp. The header does not
        define their meaning; this package reads them as seconds and
        microseconds of the server's clock (see docs/leica-emscon.md).
    values : tuple of float
        ``dVal1..3``: X, Y, Z in the length unit set (a ``ProbeMeasValueT``'s
        ``dPosition1..3``: the probe tip).
    quaternion : tuple of 4 float or None
        A ``ProbeMeasValueT``'s ``dQuaternion0..3`` (scalar first, the probe's
        orientation in the server's frame); None in a ``MeasValueT`` (a reflector).
    rotation_status : int
        A ``ProbeMeasValueT``'s ``lRotationStatus`` (bit 0: 6-DoF valid, bit 1:
        6-DoF error); 0 in a ``MeasValueT``.
    """

    status: int
    time1: int
    time2: int
    values: tuple[float, float, float]
    quaternion: tuple[float, float, float, float] | None = None
    rotation_status: int = 0

    @property
    def time_us(self) -> int:
        """The stamp as one count of microseconds (``lTime1 * 10**6 + lTime2``)."""
        return self.time1 * 1_000_000 + self.time2


@dataclass(frozen=True)
class MultiMeasResult:
    """``ES_DT_MultiMeasResult`` (or ``ES_DT_ContinuousProbeMeasResult``, a 6-DoF probe's
    ``ProbeContinuousResultT``, whose records carry a quaternion): continuous-mode points.

    Attributes
    ----------
    status : int
        ``ES_ResultStatus`` of the packet.
    meas_mode : int
        ``ES_MeasMode`` the points were taken in.
    try_mode : bool
        ``bIsTryMode``.
    meteo : tuple of float
        ``dTemperature, dPressure, dHumidity``.
    records : tuple of MeasValue
        The ``lNumberOfResults`` points, in the server's order.
    """

    status: int
    meas_mode: int
    try_mode: bool
    meteo: tuple[float, float, float]
    records: tuple[MeasValue, ...]


@dataclass(frozen=True)
class StatusChangeEvent:
    """``ES_DT_SystemStatusChange``: an unsolicited event."""

    change: int


@dataclass(frozen=True)
class OtherPacket:
    """A well-sized packet of a type the adapter does not use (nivel, reflector position,
    extended continuous results, type 10): skipped by its size."""

    type: int


Packet = (
    CommandReply
    | ErrorResponse
    | SingleMeasResult
    | ProbeStationaryResult
    | StatusChangeEvent
    | MultiMeasResult
    | OtherPacket
)
MeasResult = SingleMeasResult | ProbeStationaryResult


# ---------------------------------------------------------------- encoding


def _with_header(type_: int, body: bytes) -> bytes:
    return HEADER.pack(HEADER.size + len(body), type_) + body


def encode_command(command: int, params: bytes = b"") -> bytes:
    """A client command packet: header, ``command``, then its parameters."""
    return _with_header(DataType.COMMAND, _CMD.pack(command) + params)


def encode_reply(command: int, status: int, body: bytes = b"") -> bytes:
    """A server command reply: header, ``command``, ``status``, then its data."""
    return _with_header(DataType.COMMAND, _CMD_REPLY.pack(command, status) + body)


def encode_error(command: int, status: int) -> bytes:
    return _with_header(DataType.ERROR, _CMD_REPLY.pack(command, status))


def encode_status_change(change: int) -> bytes:
    return _with_header(DataType.SYSTEM_STATUS_CHANGE, _CMD.pack(change))


def encode_single_meas_result(
    values: Sequence[float],
    std: Sequence[float],
    meteo: Sequence[float],
    *,
    status: int = 0,
    try_mode: bool = False,
) -> bytes:
    """A ``SingleMeasResult``; ``std`` is ``(s1, s2, s3, total)``; pointing errors and
    a-priori stds are sent as zero and the a-priori std total as ``std[3]``."""
    fields = (*values, *std, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, std[3], *meteo)
    body = _CMD.pack(status) + _RESULT.pack(MM_STATIONARY, int(try_mode), *fields)
    return _with_header(DataType.SINGLE_MEAS_RESULT, body)


def encode_probe_stationary_result(
    values: Sequence[float],
    std: Sequence[float],
    quaternion: Sequence[float],
    meteo: Sequence[float],
    *,
    status: int = 0,
    try_mode: bool = False,
    rotation_std: Sequence[float] = (0.0, 0.0, 0.0, 0.0),
) -> bytes:
    """A ``ProbeStationaryResult``; covariances, a-priori values and rotation angles zero,
    rotation status "6-DoF valid"."""
    ints = (MM_STATIONARY, int(try_mode), 0, 1, 0, 0, 0, 0, 0)
    doubles = (
        *values, *std, 0.0, 0.0, 0.0, *std, 0.0, 0.0, 0.0,
        *quaternion, 0.0, 0.0, 0.0, *rotation_std, 0.0, 0.0, 0.0, *rotation_std,
        0.0, 0.0, 0.0, *meteo,
    )  # fmt: skip
    body = _CMD.pack(status) + _PROBE.pack(*ints, *doubles)
    return _with_header(DataType.STATIONARY_PROBE_MEAS_RESULT, body)


def encode_multi_meas_result(
    records: Sequence[tuple[int, int, Sequence[float]]],
    meteo: Sequence[float],
    *,
    meas_mode: int = MM_CONTINUOUS_TIME,
    status: int = 0,
    try_mode: bool = False,
) -> bytes:
    """A ``MultiMeasResult``: ``records`` are ``(ES_MeasurementStatus, time_us, (x, y, z))``.

    The stamp is written as ``lTime1`` seconds and ``lTime2`` microseconds.
    """
    head = _CMD.pack(status) + _MULTI_HEAD.pack(len(records), meas_mode, int(try_mode), *meteo)
    body = b"".join(
        _MEAS_VALUE.pack(st, t_us // 1_000_000, t_us % 1_000_000, *xyz) for st, t_us, xyz in records
    )
    return _with_header(DataType.MULTI_MEAS_RESULT, head + body)


def encode_probe_continuous_result(
    records: Sequence[tuple[int, int, Sequence[float], Sequence[float]]],
    meteo: Sequence[float],
    *,
    meas_mode: int = MM_6D_CONTINUOUS_TIME,
    status: int = 0,
    try_mode: bool = False,
    rotation_status: int = 1,
) -> bytes:
    """A ``ProbeContinuousResultT`` (``ES_DT_ContinuousProbeMeasResult``): ``records`` are
    ``(ES_MeasurementStatus, time_us, (x, y, z), (q0, q1, q2, q3))``, quaternion scalar
    first; standard deviations, covariances and rotation angles zero, probe and tip ids
    zero, ``lRotationStatus`` as given (1: "6-DoF valid, no error")."""
    head = _CMD.pack(status) + _PROBE_MULTI_HEAD.pack(
        len(records), meas_mode, int(try_mode), 0, 0, 0, 0, 0, *meteo
    )
    body = b"".join(
        _PROBE_MEAS_VALUE.pack(
            st,
            0,
            rotation_status,
            t_us // 1_000_000,
            t_us % 1_000_000,
            *xyz,
            *(0.0,) * 7,
            *quaternion,
            *(0.0,) * 10,
        )  # fmt: skip
        for st, t_us, xyz, quaternion in records
    )
    return _with_header(DataType.CONTINUOUS_PROBE_MEAS_RESULT, head + body)


def continuous_time_params(time_separation_ms: int, number_of_points: int = 0) -> bytes:
    """``ContinuousTimeModeDataT`` without a region (``bUseRegion`` false)."""
    return _CONT_TIME.pack(time_separation_ms, number_of_points, 0, RT_SPHERE)


def parse_continuous_time(body: bytes) -> tuple[int, int]:
    """``(lTimeSeparation, lNumberOfPoints)`` of ``ContinuousTimeModeDataT``."""
    separation, points, _, _ = _CONT_TIME.unpack_from(body)
    return separation, points


def continuous_distance_params(spatial_distance: float, number_of_points: int = 0) -> bytes:
    """``ContinuousDistanceModeDataT`` without a region (length unit set)."""
    return _CONT_DIST.pack(spatial_distance, number_of_points, 0, RT_SPHERE)


def parse_continuous_distance(body: bytes) -> tuple[float, int]:
    """``(dSpatialDistance, lNumberOfPoints)`` of ``ContinuousDistanceModeDataT``."""
    distance, points, _, _ = _CONT_DIST.unpack_from(body)
    return distance, points


def units_params(
    length: int = LU_MILLIMETER,
    angle: int = AU_RADIAN,
    temp: int = TU_CELSIUS,
    press: int = PU_HPASCAL,
) -> bytes:
    """``SystemUnitsDataT``: length, angle, temperature, pressure, humidity units."""
    return _UNITS.pack(length, angle, temp, press, HU_RH)


def parse_units(body: bytes) -> tuple[int, int, int, int, int]:
    return _UNITS.unpack_from(body)


def env_params(temperature: float, pressure: float, humidity: float) -> bytes:
    """``EnvironmentDataT``: temperature, pressure, humidity in the units set."""
    return _ENV.pack(temperature, pressure, humidity)


def parse_env(body: bytes) -> tuple[float, float, float]:
    return _ENV.unpack_from(body)


def uint_param(value: int) -> bytes:
    return _CMD.pack(value)


def parse_uint(body: bytes) -> int:
    return _CMD.unpack_from(body)[0]


def double_param(value: float) -> bytes:
    return struct.pack("<d", value)


def go_position_params(point: Iterable[float], use_adm: bool) -> bytes:
    """``GoPositionCT`` data: ``dVal1..3`` in the frame and units set, then ``bUseADM``."""
    return struct.pack("<3di", *point, int(use_adm))


def parse_go_position(body: bytes) -> tuple[tuple[float, float, float], bool]:
    *point, use_adm = struct.unpack_from("<3di", body)
    return (point[0], point[1], point[2]), bool(use_adm)


def stationary_params(meas_time_ms: int, use_adm: bool) -> bytes:
    """``StationaryModeDataT``: ``lMeasTime`` (ms), ``bUseADM``."""
    return struct.pack("<ii", meas_time_ms, int(use_adm))


def parse_stationary(body: bytes) -> tuple[int, bool]:
    """``(lMeasTime, bUseADM)`` of ``StationaryModeDataT``."""
    meas_time_ms, use_adm = struct.unpack_from("<ii", body)
    return meas_time_ms, bool(use_adm)


def system_status_body(
    processor: int,
    serial: int,
    version: tuple[int, int, int] = (3, 6, 0),
    last_status: int = 0,
    laser: int = 3,
    weather: int = 0,
) -> bytes:
    """Data of the ``GetSystemStatus`` reply (ADM ready; by default the laser ready and no
    weather monitor, see :class:`LaserStatus` and :class:`WeatherMonitor`)."""
    return _SYSTEM_STATUS.pack(last_status, processor, laser, 2, *version, weather, 0, serial)


@dataclass(frozen=True)
class SystemStatus:
    """``GetSystemStatus`` data."""

    last_status: int
    processor: int
    laser: int
    adm: int
    version: tuple[int, int, int]
    weather_monitor: int
    flags: int
    serial: int

    @property
    def initialised(self) -> bool:
        return self.processor == ProcessorStatus.INITIALIZED


def parse_system_status(body: bytes) -> SystemStatus:
    f = _SYSTEM_STATUS.unpack_from(body)
    return SystemStatus(f[0], f[1], f[2], f[3], (f[4], f[5], f[6]), f[7], f[8], f[9])


# ---------------------------------------------------------------- framing and decoding


def split_header(data: bytes | bytearray) -> tuple[int, int]:
    """``(lPacketSize, type)`` of a header, after bounds checks.

    The bound depends on the type: a multi-measurement result may reach
    :data:`MAX_PACKET`; every other packet stays under :data:`MAX_FIXED_PACKET`.

    Raises
    ------
    PacketSizeError
        Size below the smallest packet (12) or above the type's bound.
    """
    size, type_ = HEADER.unpack_from(data)
    bound = MAX_PACKET if type_ in VARIABLE_SIZES else MAX_FIXED_PACKET
    if not SIZE_COMMAND <= size <= bound:
        raise PacketSizeError(f"lPacketSize {size} out of bounds (type {type_})")
    return size, type_


def decode_server_packet(data: bytes) -> Packet:
    """Decode one complete server-to-client packet (``len(data) == lPacketSize``).

    Raises
    ------
    PacketSizeError
        The size disagrees with the type (or, for a command reply, with the command).
    ValueError
        Unknown packet type.
    """
    size, type_ = split_header(data)
    if size != len(data):
        raise PacketSizeError(f"lPacketSize {size} but {len(data)} bytes")
    if type_ == DataType.COMMAND:
        if size < SIZE_COMMAND_REPLY:
            raise PacketSizeError(f"command reply of {size} bytes")
        command, status = _CMD_REPLY.unpack_from(data, HEADER.size)
        expected = reply_size(command)
        # A refusal carries no data; a known command's OK reply must have its full size.
        known = command in Command._value2member_map_
        if known and size != expected and not (status != 0 and size == SIZE_COMMAND_REPLY):
            msg = f"reply to command {command} has {size} bytes, expected {expected}"
            raise PacketSizeError(msg)
        return CommandReply(command, status, data[SIZE_COMMAND_REPLY:])
    try:
        dtype = DataType(type_)
    except ValueError:
        # Not a type of the V3.6 header: the size field cannot be checked against
        # any layout, so it cannot be trusted to find the next packet either.
        raise ValueError(f"unknown packet type {type_} ({size} bytes)") from None
    if dtype in VARIABLE_SIZES:
        head, record = VARIABLE_SIZES[dtype]
        count = (size - head) // record if size >= head else -1
        if count < 0 or size != head + count * record:
            msg = f"{dtype.name} packet of {size} bytes is not {head} + n * {record}"
            raise PacketSizeError(msg)
        (claimed,) = _CMD.unpack_from(data, SIZE_COMMAND)
        if claimed != count:
            msg = f"{dtype.name} claims {claimed} results but carries {count}"
            raise PacketSizeError(msg)
        if dtype is DataType.MULTI_MEAS_RESULT:
            return _decode_multi(data, count)
        if dtype is DataType.CONTINUOUS_PROBE_MEAS_RESULT:
            return _decode_probe_multi(data, count)
        return OtherPacket(type_)  # extended continuous results (type 10): not requested
    if size != FIXED_SIZES[dtype]:
        raise PacketSizeError(
            f"{dtype.name} packet has lPacketSize {size}, expected {FIXED_SIZES[dtype]}"
        )
    if dtype is DataType.ERROR:
        return ErrorResponse(*_CMD_REPLY.unpack_from(data, HEADER.size))
    if dtype is DataType.SYSTEM_STATUS_CHANGE:
        return StatusChangeEvent(_CMD.unpack_from(data, HEADER.size)[0])
    if dtype is DataType.SINGLE_MEAS_RESULT:
        (status,) = _CMD.unpack_from(data, HEADER.size)
        f = _RESULT.unpack_from(data, SIZE_COMMAND)
        return SingleMeasResult(status, f[0], bool(f[1]), f[2:5], f[5:9], f[16:19])
    if dtype is DataType.SINGLE_MEAS_RESULT2:
        (status,) = _CMD.unpack_from(data, HEADER.size)
        f = _RESULT2.unpack_from(data, SIZE_COMMAND)
        return SingleMeasResult(status, f[0], bool(f[1]), f[2:5], f[5:9], f[22:25])
    if dtype is DataType.STATIONARY_PROBE_MEAS_RESULT:
        (status,) = _CMD.unpack_from(data, HEADER.size)
        f = _PROBE.unpack_from(data, SIZE_COMMAND)
        d = f[9:]
        return ProbeStationaryResult(
            status, f[0], bool(f[1]), d[0:3], d[3:7], d[17:21], d[24:28], d[38:41], f[3]
        )
    return OtherPacket(type_)


def _decode_multi(data: bytes, count: int) -> MultiMeasResult:
    (status,) = _CMD.unpack_from(data, HEADER.size)
    _, mode, try_mode, *meteo = _MULTI_HEAD.unpack_from(data, SIZE_COMMAND)
    offset = SIZE_COMMAND + _MULTI_HEAD.size
    records = []
    for i in range(count):
        st, t1, t2, *xyz = _MEAS_VALUE.unpack_from(data, offset + i * _MEAS_VALUE.size)
        records.append(MeasValue(st, t1, t2, (xyz[0], xyz[1], xyz[2])))
    return MultiMeasResult(
        status, mode, bool(try_mode), (meteo[0], meteo[1], meteo[2]), tuple(records)
    )


def _decode_probe_multi(data: bytes, count: int) -> MultiMeasResult:
    (status,) = _CMD.unpack_from(data, HEADER.size)
    head = _PROBE_MULTI_HEAD.unpack_from(data, SIZE_COMMAND)
    mode, try_mode, meteo = head[1], head[2], head[8:11]
    offset = SIZE_COMMAND + _PROBE_MULTI_HEAD.size
    records = []
    for i in range(count):
        f = _PROBE_MEAS_VALUE.unpack_from(data, offset + i * _PROBE_MEAS_VALUE.size)
        st, _trigger, rot_status, t1, t2 = f[:5]
        d = f[5:]
        quaternion = (d[10], d[11], d[12], d[13])
        records.append(MeasValue(st, t1, t2, (d[0], d[1], d[2]), quaternion, rot_status))
    return MultiMeasResult(
        status, mode, bool(try_mode), (meteo[0], meteo[1], meteo[2]), tuple(records)
    )


def decode_client_packet(data: bytes) -> tuple[int, bytes]:
    """``(command, params)`` of one complete client-to-server command packet.

    Raises
    ------
    PacketSizeError
        Size disagrees with the command.
    ValueError
        Not a command packet.
    """
    size, type_ = split_header(data)
    if type_ != DataType.COMMAND:
        raise ValueError(f"client sent packet type {type_}, expected a command")
    (command,) = _CMD.unpack_from(data, HEADER.size)
    known = command in Command._value2member_map_
    if size != len(data) or (known and size != command_size(command)):
        raise PacketSizeError(
            f"command {command} has {size} bytes, expected {command_size(command)}"
        )
    return command, data[SIZE_COMMAND:]
