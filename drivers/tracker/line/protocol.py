"""The tracker line protocol: framing, CRC, parsing. Pure functions, no I/O.

A frame is one ASCII line ``<body>*<HHHH>\\r\\n`` of at most
:data:`MAX_FRAME` bytes, where ``HHHH`` is the upper-case hex CRC-16/CCITT
of the body (``binascii.crc_hqx(body, 0xFFFF)``). Bodies are comma-separated
fields:

- host -> tracker: ``<seq>,<CMD>[,args...]`` with ``seq`` in 1..9999;
- tracker -> host: ``OK,<seq>[,fields...]``, ``ER,<seq>,<code>,<text>[,detail]``
  and unsolicited ``EV,0,<code>,<text>[,detail]``.

The full specification is ``docs/tracker-protocol.md``; this module is its
reference implementation and is shared by the driver and the simulator.
"""

from __future__ import annotations

import binascii
import enum
import math
import re
from dataclasses import dataclass

import numpy as np

from drivers.tracker.errors import ChecksumError, FrameError

TERMINATOR = b"\r\n"
MAX_FRAME = 256  # bytes including "*HHHH\r\n"; keeps a frame inside one small buffer
SEQ_MAX = 9999  # sequence numbers run 1..SEQ_MAX and wrap; 0 marks events
EVENT_SEQ = 0

# The grammar of docs/tracker-protocol.md ("Numbers"). Python's float() and int()
# take far more (exponents, '_', '+', spaces, 'inf', unicode digits, any length):
# every number on the wire goes through these instead.
_NUMBER = re.compile(r"-?(?:0|[1-9][0-9]{0,8})(?:\.[0-9]{1,9})?", re.ASCII)
_SEQ = re.compile(r"[1-9][0-9]{0,3}", re.ASCII)
_CODE = re.compile(r"0|[1-9][0-9]{0,2}", re.ASCII)
_TIME_US = re.compile(r"0|[1-9][0-9]{0,14}", re.ASCII)
_CRC = re.compile(rb"[0-9A-F]{4}")
_PRINTABLE = re.compile(rb"[\x20-\x7e]*")
MAX_INT_DIGITS = 9  # of a number: +-999999999.x mm is far beyond any tracker's range
MAX_DECIMALS = 9


class ErrorCode(enum.IntEnum):
    """Codes of ``ER`` and ``EV`` frames."""

    UNKNOWN_COMMAND = 1
    BAD_PARAMETER = 2
    BUSY = 3
    NOT_INITIALISED = 4
    NO_TARGET = 5
    BEAM_BROKEN = 6
    TARGET_UNSTABLE = 7
    OUT_OF_RANGE = 8
    METEO_OUT_OF_RANGE = 9
    NOT_WARMED_UP = 10
    BAD_FRAME = 11
    BEAM_RESTORED = 20  # event only
    REPLAY_MISMATCH = 90  # simulator replay only


class ReadingStatus(enum.Enum):
    """Quality flag the tracker attaches to each reading."""

    ACCURATE = "ACC"
    INACCURATE = "INACC"
    UNSTABLE = "UNSTABLE"


# ---------------------------------------------------------------- framing


def crc16(body: bytes) -> int:
    """CRC-16/CCITT (poly 0x1021, init 0xFFFF, no reflection) of ``body``."""
    return binascii.crc_hqx(body, 0xFFFF)


def encode_frame(body: str | bytes) -> bytes:
    """Wrap a body into a complete frame ``body*HHHH\\r\\n``.

    Raises
    ------
    ValueError
        If the body contains ``*``, CR or LF, is not ASCII, or the frame would
        exceed :data:`MAX_FRAME` bytes.
    """
    raw = body.encode("ascii") if isinstance(body, str) else bytes(body)
    if b"*" in raw or b"\r" in raw or b"\n" in raw:
        raise ValueError(f"frame body must not contain '*', CR or LF: {raw!r}")
    frame = raw + b"*%04X\r\n" % crc16(raw)
    if len(frame) > MAX_FRAME:
        raise ValueError(f"frame of {len(frame)} bytes exceeds {MAX_FRAME}")
    return frame


def decode_frame(line: bytes) -> str:
    """Check one received line and return its body as text.

    Parameters
    ----------
    line : bytes
        One line, with or without the trailing ``\\r\\n``.

    Raises
    ------
    FrameError
        If the line is too long, not ASCII, or lacks ``*HHHH``.
    ChecksumError
        If the CRC does not match the body.
    """
    if len(line) > MAX_FRAME:
        raise FrameError(f"line of {len(line)} bytes exceeds {MAX_FRAME}")
    if line.endswith(TERMINATOR):
        line = line[:-2]
    star = line.rfind(b"*")
    if star < 0 or len(line) - star != 5:
        raise FrameError(f"no '*HHHH' checksum in {line[:60]!r}")
    raw, crc_text = line[:star], line[star + 1 :]
    if not _CRC.fullmatch(crc_text) or not _PRINTABLE.fullmatch(raw):
        raise FrameError(f"garbled frame {line[:60]!r}")
    sent = int(crc_text, 16)
    body = raw.decode("ascii")
    if sent != crc16(raw):
        raise ChecksumError(f"checksum {sent:04X} != {crc16(raw):04X} for {line[:60]!r}")
    return body


# ---------------------------------------------------------------- commands


def next_seq(seq: int) -> int:
    """Sequence number following ``seq`` (1..SEQ_MAX, wrapping, never 0)."""
    return seq % SEQ_MAX + 1


def format_number(value: float, decimals: int) -> str:
    """Fixed-point text of a finite number in the protocol's grammar (never an exponent).

    Raises
    ------
    ValueError
        If the value is not finite, or needs more than 9 digits before or after the point.
    """
    if not math.isfinite(value):
        raise ValueError(f"not a finite number: {value}")
    if not 0 <= decimals <= MAX_DECIMALS:
        raise ValueError(f"{decimals} decimals: the protocol carries 0..{MAX_DECIMALS}")
    text = f"{value:.{decimals}f}"
    if text.lstrip("-").strip("0.") == "":
        return "0." + "0" * decimals if decimals else "0"
    if not _NUMBER.fullmatch(text):
        raise ValueError(f"{value} needs more than {MAX_INT_DIGITS} digits before the point")
    return text


def parse_number(text: str) -> float:
    """A decimal in the protocol's grammar: ``-?(0|[1-9][0-9]{0,8})(\\.[0-9]{1,9})?``.

    Raises
    ------
    ValueError
        If ``text`` has an exponent, ``+``, ``_``, spaces, leading zeros,
        ``inf``/``nan``, or too many digits.
    """
    if not _NUMBER.fullmatch(text):
        raise ValueError(f"not a protocol number: {text[:40]!r}")
    return float(text)


def command_body(seq: int, command: str, *args: object) -> str:
    """Body ``<seq>,<CMD>[,args]`` of a host frame; args are already formatted text."""
    if not 1 <= seq <= SEQ_MAX:
        raise ValueError(f"sequence number {seq} outside 1..{SEQ_MAX}")
    fields = [str(seq), command, *(str(a) for a in args)]
    for f in fields:
        if "," in f or "*" in f:
            raise ValueError(f"field {f!r} contains ',' or '*'")
    return ",".join(fields)


@dataclass(frozen=True)
class Command:
    """A parsed host frame."""

    seq: int
    name: str
    args: tuple[str, ...]


def parse_command(body: str) -> Command:
    """Parse a host frame body ``<seq>,<CMD>[,args]`` (used by the simulator).

    Raises
    ------
    FrameError
        If the sequence number is missing or not in 1..SEQ_MAX.
    """
    fields = body.split(",")
    if len(fields) < 2 or not _SEQ.fullmatch(fields[0]) or not fields[1]:
        raise FrameError(f"bad command frame {body[:60]!r}")
    return Command(int(fields[0]), fields[1], tuple(fields[2:]))


# ---------------------------------------------------------------- replies


class ReplyKind(enum.Enum):
    OK = "OK"
    ER = "ER"
    EV = "EV"


@dataclass(frozen=True)
class Reply:
    """A parsed tracker frame.

    Attributes
    ----------
    kind : ReplyKind
        OK, ER or EV.
    seq : int
        Sequence number of the command answered (0 for events).
    fields : tuple of str
        Fields after the sequence number. For ER/EV: ``(code, text[, detail])``.
    """

    kind: ReplyKind
    seq: int
    fields: tuple[str, ...]

    @property
    def code(self) -> int:
        """Error/event code of an ER or EV frame."""
        return int(self.fields[0])

    @property
    def text(self) -> str:
        return self.fields[1] if len(self.fields) > 1 else ""

    @property
    def detail(self) -> str:
        return ",".join(self.fields[2:])


def parse_reply(body: str) -> Reply:
    """Parse a tracker frame body.

    Raises
    ------
    FrameError
        If the kind is unknown, the sequence number is not 1..9999 (``0`` for
        an event, and only for it), or an ER/EV frame lacks a plain code.
    """
    fields = body.split(",")
    if len(fields) < 2 or fields[0] not in ("OK", "ER", "EV"):
        raise FrameError(f"not a reply frame: {body[:60]!r}")
    kind = ReplyKind(fields[0])
    seq_ok = fields[1] == "0" if kind is ReplyKind.EV else _SEQ.fullmatch(fields[1])
    if not seq_ok:
        raise FrameError(f"bad sequence number in {body[:60]!r}")
    rest = tuple(fields[2:])
    if kind is not ReplyKind.OK and (not rest or not _CODE.fullmatch(rest[0])):
        raise FrameError(f"{kind.value} frame without code: {body[:60]!r}")
    return Reply(kind, int(fields[1]), rest)


def ok_body(seq: int, *fields: object) -> str:
    """Body of an ``OK`` reply."""
    return ",".join(["OK", str(seq), *(str(f) for f in fields)])


def error_body(seq: int, code: ErrorCode, detail: str = "") -> str:
    """Body of an ``ER`` reply (or an ``EV`` event when ``seq`` is 0)."""
    kind = "EV" if seq == EVENT_SEQ else "ER"
    fields = [kind, str(seq), str(int(code)), code.name]
    if detail:
        # Printable ASCII without ',' or '*', cut so the frame stays within MAX_FRAME.
        room = MAX_FRAME - len(",".join(fields)) - len(",*HHHH\r\n")
        text = "".join(c if " " <= c <= "~" else "?" for c in detail)
        fields.append(text.replace(",", ";").replace("*", "x")[:room])
    return ",".join(fields)


# ---------------------------------------------------------------- readings

POINT_DECIMALS = 4  # 0.1 um: well below the tracker's noise
ANGLE_DECIMALS = 8  # 10 nrad


@dataclass(frozen=True)
class Reading:
    """One tracker reading in the tracker frame.

    Attributes
    ----------
    point_mm : numpy.ndarray, shape (3,)
        Target position in the tracker frame, mm.
    rotvec_rad : numpy.ndarray, shape (3,), or None
        Orientation of a 6-DoF probe as a rotation vector (probe to tracker
        frame), rad; None for a plain reflector.
    status : ReadingStatus
        Quality flag sent with the reading.
    device_time_us : int
        Tracker clock at the reading, microseconds.
    """

    point_mm: np.ndarray
    rotvec_rad: np.ndarray | None
    status: ReadingStatus
    device_time_us: int

    @property
    def accurate(self) -> bool:
        return self.status is ReadingStatus.ACCURATE


def reading_fields(
    point: np.ndarray, rotvec: np.ndarray | None, status: ReadingStatus, device_time_us: int
) -> tuple[str, ...]:
    """Fields of a ``MEAS`` reply after the sequence number (values already in wire units)."""
    if rotvec is None:
        values = ["P3", *(format_number(v, POINT_DECIMALS) for v in point)]
    else:
        values = [
            "P6",
            *(format_number(v, POINT_DECIMALS) for v in point),
            *(format_number(v, ANGLE_DECIMALS) for v in rotvec),
        ]
    return (*values, status.value, str(int(device_time_us)))


def parse_reading(
    fields: tuple[str, ...], length_scale: float = 1.0, angle_scale: float = 1.0
) -> Reading:
    """Parse the fields of a ``MEAS`` reply into a :class:`Reading`.

    Parameters
    ----------
    fields : tuple of str
        ``P3,x,y,z,status,t_us`` or ``P6,x,y,z,rx,ry,rz,status,t_us``.
    length_scale, angle_scale : float
        Factors from wire units to mm and rad (1.0 for ``UNITS,MM,RAD``).

    Raises
    ------
    FrameError
        If the field count, tag, numbers or status flag are wrong.
    """
    n_values = _READING_VALUES.get(fields[0]) if fields else None
    if n_values is None or len(fields) != n_values + 3:
        raise FrameError(f"bad reading fields {fields!r}")
    try:
        values = [parse_number(v) for v in fields[1 : 1 + n_values]]
        status = _STATUS_BY_TEXT[fields[-2]]
    except (ValueError, KeyError):
        raise FrameError(f"bad reading fields {fields!r}") from None
    if not _TIME_US.fullmatch(fields[-1]):
        raise FrameError(f"bad device time in reading fields {fields!r}")
    device_time_us = int(fields[-1])
    point = np.array(values[:3]) * length_scale
    rotvec = np.array(values[3:]) * angle_scale if n_values == 6 else None
    return Reading(point, rotvec, status, device_time_us)


_READING_VALUES = {"P3": 3, "P6": 6}  # tag -> number of values after it
_STATUS_BY_TEXT = {s.value: s for s in ReadingStatus}

LENGTH_UNITS = {"MM": 1.0, "M": 1000.0}  # wire unit -> mm
ANGLE_UNITS = {"RAD": 1.0, "DEG": math.pi / 180.0}  # wire unit -> rad


# ---------------------------------------------------------------- streams
#
# ``STREAM,<rate_hz>[,<count>]`` starts continuous measurement; the tracker then
# sends one stream frame per tick until ``STOP`` (or until ``count`` samples):
#
#     SR,<id>,<n>,P3,<x>,<y>,<z>,<status>,<t_us>           a reading
#     SR,<id>,<n>,P6,<x>,<y>,<z>,<rx>,<ry>,<rz>,<status>,<t_us>
#     SR,<id>,<n>,NONE,<code>,<t_us>                       no reading at this tick
#     SR,<id>,<n>,END,<t_us>                               the last of ``count`` was n
#
# ``id`` is the sequence number of the STREAM command (a frame of an earlier
# stream is recognised and dropped), ``n`` counts the stream's ticks from 1 (a
# gap is a lost sample, a repeat or step back a stale one).

STREAM_TAG = "SR"
MAX_STREAM_RATE_HZ = 1000  # LMF's continuous mode tops out near 1 kHz
MAX_SAMPLE = 999_999_999
_SAMPLE = re.compile(r"[1-9][0-9]{0,8}", re.ASCII)
_RATE = re.compile(r"[1-9][0-9]{0,3}", re.ASCII)


@dataclass(frozen=True)
class StreamFrame:
    """One parsed stream frame.

    Attributes
    ----------
    stream_id : int
        Sequence number of the ``STREAM`` command that started the stream.
    n : int
        Tick number within the stream, from 1; for an end frame, the last tick sent.
    reading : Reading or None
        The reading (mm, rad, tracker frame), or None at a tick without one.
    code : int
        0 with a reading; otherwise why there is none (:class:`ErrorCode`:
        ``BEAM_BROKEN``, ``NO_TARGET``, ``OUT_OF_RANGE``, ...).
    end : bool
        The stream ended here (its requested count was sent).
    device_time_us : int
        Tracker clock at the tick, microseconds.
    """

    stream_id: int
    n: int
    reading: Reading | None
    code: int
    end: bool
    device_time_us: int


def parse_stream_rate(args: tuple[str, ...]) -> tuple[int, int | None]:
    """``(rate_hz, count)`` from the arguments of ``STREAM`` (count None: until ``STOP``).

    Raises
    ------
    ValueError
        Rate not a whole number in 1..:data:`MAX_STREAM_RATE_HZ`, count not in
        1..:data:`MAX_SAMPLE`, or another number of arguments.
    """
    if len(args) not in (1, 2) or not _RATE.fullmatch(args[0]):
        raise ValueError(f"STREAM takes <rate_hz>[,<count>]: {args!r}")
    rate = int(args[0])
    if rate > MAX_STREAM_RATE_HZ:
        raise ValueError(f"rate {rate} Hz above {MAX_STREAM_RATE_HZ}")
    if len(args) == 1:
        return rate, None
    if not _SAMPLE.fullmatch(args[1]):
        raise ValueError(f"count must be 1..{MAX_SAMPLE}: {args[1]!r}")
    return rate, int(args[1])


def stream_body(stream_id: int, n: int, *fields: str) -> str:
    """Body ``SR,<id>,<n>,<fields...>`` of a stream frame (fields already formatted)."""
    if not (1 <= stream_id <= SEQ_MAX and 1 <= n <= MAX_SAMPLE):
        raise ValueError(f"stream id {stream_id} or tick {n} out of range")
    return ",".join([STREAM_TAG, str(stream_id), str(n), *fields])


def is_stream_body(body: str) -> bool:
    """Whether a valid frame's body is a stream frame (``SR,...``)."""
    return body.startswith(STREAM_TAG + ",")


def parse_stream_frame(
    body: str, length_scale: float = 1.0, angle_scale: float = 1.0
) -> StreamFrame:
    """Parse a stream frame body (its CRC already checked by :func:`decode_frame`).

    Raises
    ------
    FrameError
        Not ``SR``, a bad id or tick number, or bad reading fields.
    """
    fields = body.split(",")
    if (
        len(fields) < 5
        or fields[0] != STREAM_TAG
        or not _SEQ.fullmatch(fields[1])
        or not _SAMPLE.fullmatch(fields[2])
    ):
        raise FrameError(f"bad stream frame {body[:60]!r}")
    stream_id, n, rest = int(fields[1]), int(fields[2]), tuple(fields[3:])
    if rest[0] == "END" and len(rest) == 2 and _TIME_US.fullmatch(rest[1]):
        return StreamFrame(stream_id, n, None, 0, True, int(rest[1]))
    if rest[0] == "NONE" and len(rest) == 3 and _CODE.fullmatch(rest[1]):
        if _TIME_US.fullmatch(rest[2]) and rest[1] != "0":
            return StreamFrame(stream_id, n, None, int(rest[1]), False, int(rest[2]))
        raise FrameError(f"bad stream frame {body[:60]!r}")
    reading = parse_reading(rest, length_scale, angle_scale)
    return StreamFrame(stream_id, n, reading, 0, False, reading.device_time_us)
