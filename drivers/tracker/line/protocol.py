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
