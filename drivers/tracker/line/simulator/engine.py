"""The line protocol's front-end of the simulated tracker: one received line in, bytes out.

No I/O here: :class:`TrackerSimulator` decodes a command, asks its
:class:`~drivers.tracker.instrument.Instrument` (the tracker: target, noise,
faults, air, warm-up, latency) and encodes the reply; the servers in
:mod:`drivers.tracker.line.simulator.server` feed it lines. Its true target
is set in-process with :meth:`TrackerSimulator.set_target` or over the wire
with ``SIM,TARGET,x,y,z[,rx,ry,rz]`` (mm and rad whatever ``UNITS`` says).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from drivers.tracker.errors import FrameError
from drivers.tracker.instrument import (
    MAX_RANGE_MM,
    MIN_RANGE_MM,
    Fault,
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
    ANGLE_UNITS,
    EVENT_SEQ,
    LENGTH_UNITS,
    Command,
    ErrorCode,
    ReadingStatus,
    decode_frame,
    encode_frame,
    error_body,
    format_number,
    ok_body,
    parse_command,
    parse_number,
    parse_stream_rate,
    reading_fields,
    stream_body,
)

VENDOR = "CALIBRATOR"
MODEL = "TRACKER-SIM"
FIRMWARE = "1.0"
MODES = ("FAST", "STANDARD", "PRECISE")
METEO_LIMITS = {"T": (-10.0, 50.0), "P": (500.0, 1200.0), "H": (0.0, 100.0)}


#: What the line simulator's engine hands its server: outputs and stream control.
LineOutput = Send | HangUp | StreamStart | StreamStop | StreamStall


class TrackerSimulator(FrontEnd):
    """The line protocol spoken by a simulated laser tracker (:class:`Instrument`).

    Parameters
    ----------
    probe_6dof : bool
        True: readings carry the probe orientation (``P6`` replies).
    serial : str
        Serial number reported by ``ID?``.
    instrument : Instrument, optional
        Speak for this tracker; None builds one from ``tracker``.
    **tracker
        The tracker's parameters (:class:`~drivers.tracker.instrument.Instrument`:
        ``seed``, ``noise``, ``faults``, ``init_time_s``, ``initialised``,
        ``clock``, ``air``, ``on_s``, ``latency_s``, ``time_scale``): ``air`` is
        what ``COND?`` reports, ``on_s`` its time since power-on at start.
    """

    def __init__(
        self,
        *,
        probe_6dof: bool = False,
        serial: str = "SIM-0001",
        instrument: Instrument | None = None,
        **tracker: Any,
    ):
        super().__init__(instrument, **tracker)
        self.probe_6dof = probe_6dof
        self.serial = serial
        self._busy_until = 0.0
        self._units = ("MM", "RAD")
        self._env = (20.0, 1013.25, 50.0)
        self._mode = "STANDARD"

    # ------------------------------------------------------------ wire

    def handle_line(self, line: bytes) -> list[LineOutput]:
        """Process one received line (with its ``\\r\\n``) and return what to send."""
        with self._lock:
            try:
                cmd = parse_command(decode_frame(line))
            except FrameError as exc:
                return [bad_frame_reply(line, exc)]
            if cmd.name == "SIM":
                return [Send(encode_frame(sim_command(self.instrument, cmd)))]
            faults = self.instrument.faults.next_command(cmd.name)
            pre: list[Output] = []
            body = None
            for fault in faults:
                self.instrument.fire(fault)
                if fault.kind == "beam_break":
                    pre.append(Send(encode_frame(error_body(EVENT_SEQ, ErrorCode.BEAM_BROKEN))))
                elif fault.kind == "error":
                    body = error_body(cmd.seq, fault.code, "injected")
            post: list[LineOutput] = []
            if body is None:
                body = self._dispatch(cmd, post)
            out: list[LineOutput] = [*pre, *self._deliver(encode_frame(body), faults, cmd), *post]
            return out

    def _deliver(self, frame: bytes, faults: list[Fault], cmd: Command) -> list[Output]:
        """Apply the reply-mangling faults to a finished frame."""
        # INIT answers only when the head has finished moving.
        init_s = self.instrument.init_time_s
        delay = init_s if cmd.name == "INIT" and frame.startswith(b"OK") else 0.0
        for fault in faults:
            if fault.kind == "drop":
                return []
            if fault.kind == "hangup":
                return [HangUp()]
            if fault.kind == "garble":
                # Line noise: printable junk without '*', so it cannot pass as a frame.
                size = max(8, len(frame) - 2)
                junk = self.instrument.rng.integers(0x21, 0x7F, size=size, dtype=np.uint8)
                frame = bytes(junk).replace(b"*", b"#") + b"\r\n"
            elif fault.kind == "bad_crc":
                star = frame.rindex(b"*")
                crc = int(frame[star + 1 : star + 5], 16) ^ 0x5A5A
                frame = frame[: star + 1] + b"%04X\r\n" % crc
            elif fault.kind == "delay":
                delay += fault.delay_s
            elif fault.kind == "partial":
                cut = len(frame) // 2
                return [Send(frame[:cut], delay), Send(frame[cut:], fault.delay_s)]
        return [Send(frame, delay)]

    def _dispatch(self, cmd: Command, post: list[LineOutput]) -> str:
        now = self.instrument.clock()
        handler = _HANDLERS.get(cmd.name)
        if handler is None:
            return error_body(cmd.seq, ErrorCode.UNKNOWN_COMMAND, cmd.name)
        if now < self._busy_until and cmd.name not in ("ID?", "STAT?"):
            return error_body(cmd.seq, ErrorCode.BUSY, "initialising")
        try:
            return handler(self, cmd, now, post)
        except (ValueError, IndexError):
            return error_body(cmd.seq, ErrorCode.BAD_PARAMETER, ",".join(cmd.args))

    # ------------------------------------------------------------ commands

    def _id(self, cmd, now, post):
        return ok_body(cmd.seq, VENDOR, MODEL, self.serial, FIRMWARE)

    def _stat(self, cmd, now, post):
        locked_on = self.instrument.locked_on
        if now < self._busy_until:
            state = "BUSY"
        elif self.initialised and locked_on:
            state = "READY"
        else:
            state = "NOT_READY"
        probe = "P6" if self.probe_6dof else "P3"
        return ok_body(cmd.seq, state, int(self.initialised), int(locked_on), probe, self._mode)

    def _init(self, cmd, now, post):
        # The head moves; the OK is held back until it is done (see _deliver).
        self._busy_until = now + self.instrument.init_time_s
        self.initialised = True
        return ok_body(cmd.seq)

    def _units_cmd(self, cmd, now, post):
        length, angle = cmd.args
        if length not in LENGTH_UNITS or angle not in ANGLE_UNITS:
            raise ValueError(cmd.args)
        self._units = (length, angle)
        return ok_body(cmd.seq, length, angle)

    def _env_cmd(self, cmd, now, post):
        t, p, h = (parse_number(a) for a in cmd.args)
        for name, value in zip("TPH", (t, p, h), strict=True):
            lo, hi = METEO_LIMITS[name]
            if not lo <= value <= hi:
                return error_body(cmd.seq, ErrorCode.METEO_OUT_OF_RANGE, f"{name}={value}")
        self._env = (t, p, h)
        return ok_body(cmd.seq, *cmd.args)

    def _env_query(self, cmd, now, post):
        return ok_body(cmd.seq, *(f"{v:.2f}" for v in self._env))

    def _cond_query(self, cmd, now, post):
        if cmd.args:
            raise ValueError(cmd.args)
        on_s = self.instrument.on_s(now)
        air = (format_number(v, 2) for v in self.instrument.air)
        warm = int(self.instrument.warmed_up(now))
        return ok_body(cmd.seq, *air, format_number(on_s, 1), warm)

    def _mode_cmd(self, cmd, now, post):
        (mode,) = cmd.args
        if mode not in MODES:
            raise ValueError(mode)
        self._mode = mode
        return ok_body(cmd.seq, mode)

    def _stop(self, cmd, now, post):
        post.append(StreamStop())
        return ok_body(cmd.seq)

    def _meas(self, cmd, now, post):
        if cmd.args:
            raise ValueError(cmd.args)
        inst = self.instrument
        if not inst.initialised:
            return error_body(cmd.seq, ErrorCode.NOT_INITIALISED)
        if inst.target is None:
            return error_body(cmd.seq, ErrorCode.NO_TARGET)
        refused, restored = inst.take_broken_reading()
        if refused:
            if restored:  # the tracker re-locks on its own afterwards
                post.append(Send(encode_frame(error_body(EVENT_SEQ, ErrorCode.BEAM_RESTORED))))
            return error_body(cmd.seq, ErrorCode.BEAM_BROKEN)
        t_us = int(inst.device_s(now) * 1e6)
        if inst.motion is not None:  # a moving target: where it was at the stamp
            return self._moving_reading(cmd.seq, t_us)
        if not MIN_RANGE_MM <= inst.range_mm <= MAX_RANGE_MM:
            return error_body(cmd.seq, ErrorCode.OUT_OF_RANGE, f"{inst.range_mm:.1f} mm")
        point = inst.sample_point(inst.target, inst.noise_scale)
        point, status = self._flagged(point)
        rotvec = None
        if self.probe_6dof:
            rotvec = inst.sample_rotvec(inst.rotvec) / ANGLE_UNITS[self._units[1]]
        point = point / LENGTH_UNITS[self._units[0]]
        return ok_body(cmd.seq, *reading_fields(point, rotvec, status, t_us))

    def _flagged(self, point: np.ndarray) -> tuple[np.ndarray, ReadingStatus]:
        """A reading's point and status under the scripted flag faults (consumes one)."""
        if self.instrument.take_unstable():
            return self.instrument.scatter(point), ReadingStatus.UNSTABLE
        if self.instrument.take_inaccurate():
            return point, ReadingStatus.INACCURATE
        return point, ReadingStatus.ACCURATE

    def _moving_reading(self, seq: int, t_us: int) -> str:
        """``MEAS`` of a moving target: its reply body (a reading or an ``ER``)."""
        fields = self._tick_fields(t_us)
        if fields[0] == "NONE":
            return error_body(seq, ErrorCode(int(fields[1])))
        return ok_body(seq, *fields, str(t_us))

    def _tick_fields(self, t_us: int) -> tuple[str, ...]:
        """Reading fields for stamp ``t_us``, or ``NONE,<code>``; consumes flag faults."""
        inst = self.instrument
        if inst.target is None:
            return ("NONE", str(int(ErrorCode.NO_TARGET)))
        if inst.take_broken_reading()[0]:
            return ("NONE", str(int(ErrorCode.BEAM_BROKEN)))
        point, rot, scale = inst.pose_at(t_us / 1e6)
        if not inst.in_range(point):
            return ("NONE", str(int(ErrorCode.OUT_OF_RANGE)))
        point = inst.sample_point(point, scale)
        point, status = self._flagged(point)
        rotvec = None
        if self.probe_6dof:
            rotvec = inst.sample_rotvec(rot) / ANGLE_UNITS[self._units[1]]
        point = point / LENGTH_UNITS[self._units[0]]
        return reading_fields(point, rotvec, status, t_us)[:-1]

    # ------------------------------------------------------------ streams

    def _stream(self, cmd, now, post):
        rate, count = parse_stream_rate(cmd.args)  # ValueError: BAD_PARAMETER
        if not self.initialised:
            return error_body(cmd.seq, ErrorCode.NOT_INITIALISED)
        post.append(StreamStart(1.0 / rate, count, cmd.seq))
        return ok_body(cmd.seq, rate)

    def stream_tick(self, stream_id: int, n: int, stamp_s: float) -> list[LineOutput]:
        """Outputs of tick ``n`` of stream ``stream_id``, due at ``stamp_s`` (device time, s).

        The tick is stamped and measured at its due time on the tracker's
        clock (a server running late sends ticks late, never with a later
        position), and the fault script's ``SAMPLE`` triggers count ticks.
        """
        with self._lock:
            t_us = max(int(round(stamp_s * 1e6)), 0)
            faults = self.instrument.faults.next_command("SAMPLE", count_any=False)
            pre: list[Output] = []
            error = None
            for fault in faults:
                if fault.kind == "stall":
                    return [StreamStall(fault.delay_s)]
                if fault.kind in ("beam_break", "unstable", "inaccurate"):
                    self.instrument.fire(fault)
                if fault.kind == "beam_break":
                    pre.append(Send(encode_frame(error_body(EVENT_SEQ, ErrorCode.BEAM_BROKEN))))
                elif fault.kind == "error":
                    error = fault.code
            was_broken = self.instrument.beam_broken_left > 0
            if error is not None:
                fields: tuple[str, ...] = ("NONE", str(int(error)))
            else:
                fields = self._tick_fields(t_us)
            body = stream_body(stream_id, n, *fields, str(t_us))
            post: list[LineOutput] = []
            if was_broken and not self.instrument.beam_broken_left:  # re-locked after this tick
                post.append(Send(encode_frame(error_body(EVENT_SEQ, ErrorCode.BEAM_RESTORED))))
            tick = Command(0, "SAMPLE", ())
            return [*pre, *self._deliver(encode_frame(body), faults, tick), *post]

    def stream_end(self, stream_id: int, n: int) -> bytes:
        """The end frame of a stream whose last tick was ``n``."""
        with self._lock:
            t_us = int(self.instrument.device_time_s() * 1e6)
            return encode_frame(stream_body(stream_id, max(n, 1), "END", str(t_us)))


_HANDLERS = {
    "ID?": TrackerSimulator._id,
    "STAT?": TrackerSimulator._stat,
    "INIT": TrackerSimulator._init,
    "UNITS": TrackerSimulator._units_cmd,
    "ENV": TrackerSimulator._env_cmd,
    "ENV?": TrackerSimulator._env_query,
    "COND?": TrackerSimulator._cond_query,
    "MODE": TrackerSimulator._mode_cmd,
    "MEAS": TrackerSimulator._meas,
    "STOP": TrackerSimulator._stop,
    "STREAM": TrackerSimulator._stream,
}


def bad_frame_reply(line: bytes, exc: FrameError) -> Send:
    """The ``ER`` reply to a line that is not a valid frame (shared with replay)."""
    return Send(encode_frame(error_body(_leading_seq(line), ErrorCode.BAD_FRAME, str(exc))))


def internal_error_reply(line: bytes, exc: Exception) -> Send:
    """The ``ER`` reply when handling a line failed unexpectedly (the server stays up)."""
    detail = f"internal error: {type(exc).__name__}"
    return Send(encode_frame(error_body(_leading_seq(line), ErrorCode.BAD_PARAMETER, detail)))


def _leading_seq(line: bytes) -> int:
    """Sequence number at the start of an unreadable frame, or 0 (then the reply is an event)."""
    head = line.split(b",", 1)[0]
    return int(head) if head.isdigit() and 1 <= int(head) <= 9999 else EVENT_SEQ
