"""The simulated tracker: turns one received line into the bytes to send back.

No I/O here: :class:`TrackerSimulator` is a state machine that the servers
in :mod:`drivers.tracker.line.simulator.server` feed with lines. Its true target
is set in-process with :meth:`TrackerSimulator.set_target` or over the wire
with ``SIM,TARGET,x,y,z[,rx,ry,rz]`` (mm and rad whatever ``UNITS`` says).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from drivers.tracker.errors import FrameError
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
from drivers.tracker.line.simulator.faults import Fault, FaultSchedule, parse_fault
from drivers.tracker.line.simulator.noise import NoiseModel

VENDOR = "CALIBRATOR"
MODEL = "TRACKER-SIM"
FIRMWARE = "1.0"
MIN_RANGE_MM = 500.0  # closer than this a real tracker cannot lock on
MAX_RANGE_MM = 80_000.0
UNSTABLE_SIGMA_MM = 0.05  # extra scatter of a moving target ("outliers of tens of um")
MODES = ("FAST", "STANDARD", "PRECISE")
METEO_LIMITS = {"T": (-10.0, 50.0), "P": (500.0, 1200.0), "H": (0.0, 100.0)}
#: Time a tracker needs after power-on before it measures to its specification, s
#: (a Leica AT960: about two hours; its warm-up errors reach tenths of a millimetre).
WARM_UP_S = 2 * 3600.0


@dataclass(frozen=True)
class Send:
    """Bytes to send ``delay_s`` after the previous output of the same connection."""

    data: bytes
    delay_s: float = 0.0


@dataclass(frozen=True)
class HangUp:
    """Close the connection without a reply."""


@dataclass(frozen=True)
class StreamStart:
    """Start ticking a stream on this connection (after the ``OK`` sent before it)."""

    stream_id: int
    rate_hz: int
    count: int | None = None


@dataclass(frozen=True)
class StreamStop:
    """End this connection's stream: no tick after the outputs before it."""


@dataclass(frozen=True)
class StreamStall:
    """The stream falls silent for ``delay_s``; the ticks due meanwhile are lost."""

    delay_s: float


Output = Send | HangUp
#: What the line simulator's engine hands its server: outputs and stream control.
LineOutput = Send | HangUp | StreamStart | StreamStop | StreamStall
#: Most waypoints a ``SIM,PATH`` may hold (bounds the memory a client can take).
MAX_WAYPOINTS = 200_000


class TrackerSimulator:
    """A laser tracker at the origin of the tracker frame, measuring one target.

    Parameters
    ----------
    seed : int
        Seed of the noise generator (``numpy.random.default_rng``).
    noise : NoiseModel
        Noise model; ``NoiseModel(enabled=False)`` for exact readings.
    probe_6dof : bool
        True: readings carry the probe orientation (``P6`` replies).
    faults : list of Fault, optional
        Faults armed from the start.
    init_time_s : float
        Duration of ``INIT`` (a real tracker takes tens of seconds).
    initialised : bool
        Start already initialised (a tracker that was initialised earlier).
    serial : str
        Serial number reported by ``ID?``.
    clock : callable
        Monotonic clock in seconds (device timestamps, INIT duration).
    air : tuple of float
        What the station's sensors measure of the air: degC, hPa, %RH (``COND?``).
    on_s : float
        Time since power-on at start, s (``COND?``; warmed up after
        :data:`WARM_UP_S`).
    latency_s : float
        How late the tracker's stamps are: a reading stamped ``t`` shows a
        moving target where it was at ``t - latency_s`` (device clock, s).
    time_scale : float
        How many times faster than the wall clock ``clock`` runs (stream
        ticks are stamped at their due times on it).
    """

    def __init__(
        self,
        *,
        seed: int = 0,
        noise: NoiseModel | None = None,
        probe_6dof: bool = False,
        faults: list[Fault] | None = None,
        init_time_s: float = 0.2,
        initialised: bool = False,
        serial: str = "SIM-0001",
        clock: Callable[[], float] = time.monotonic,
        air: tuple[float, float, float] = (20.0, 1013.25, 50.0),
        on_s: float = 3 * 3600.0,
        latency_s: float = 0.0,
        time_scale: float = 1.0,
    ):
        self._rng = np.random.default_rng(seed)
        self.noise = noise if noise is not None else NoiseModel()
        self.probe_6dof = probe_6dof
        self.init_time_s = init_time_s
        self.serial = serial
        self._clock = clock
        self._t0 = clock()
        self._lock = threading.Lock()  # set_target may come from another thread
        self._faults = FaultSchedule(faults)
        self.initialised = initialised
        self._busy_until = 0.0
        self._target: np.ndarray | None = None
        self._target_rotvec = np.zeros(3)
        self._beam_broken_left = 0
        self._unstable_left = 0
        self._inaccurate_left = 0
        self._units = ("MM", "RAD")
        self._env = (20.0, 1013.25, 50.0)
        self._mode = "STANDARD"
        self.air = tuple(float(v) for v in air)
        self._on_s0 = float(on_s)
        self.latency_s = float(latency_s)
        self.time_scale = float(time_scale)
        # A moving target: device time (s) -> 3 or 6 values (mm, rad); None: static.
        self._motion: Callable[[float], ArrayLike] | None = None
        self._waypoints: list[list[float]] = []

    # ------------------------------------------------------------ in-process control

    def set_target(self, point_mm: ArrayLike, rotvec_rad: ArrayLike | None = None) -> None:
        """Tell the simulator where the target truly is; re-acquires a broken beam.

        Parameters
        ----------
        point_mm : array_like, shape (3,)
            True target position in the tracker frame, mm.
        rotvec_rad : array_like, shape (3,), optional
            True probe orientation (probe to tracker frame) as a rotation
            vector, rad; zero rotation when omitted.
        """
        with self._lock:
            self._set_target(point_mm, rotvec_rad)

    def _set_target(self, point_mm, rotvec_rad) -> None:
        point = np.asarray(point_mm, dtype=float).reshape(3)
        rot = np.zeros(3) if rotvec_rad is None else np.asarray(rotvec_rad, float).reshape(3)
        if not (np.all(np.isfinite(point)) and np.all(np.isfinite(rot))):
            raise ValueError("target position and orientation must be finite")
        self._target, self._target_rotvec = point, rot
        self._beam_broken_left = 0
        # Per-target constants, computed once: a reading must cost microseconds.
        self._range_mm = float(np.linalg.norm(point))
        self._noise_scale = self.noise.scale_matrix(point) if self._range_mm > 0 else None

    def clear_target(self) -> None:
        """Remove the target (the beam has nothing to lock on)."""
        with self._lock:
            self._target = None
            self._motion = None

    def set_motion(self, motion: Callable[[float], ArrayLike] | None) -> None:
        """Move the target along ``motion`` (None: hold it where it is now).

        Parameters
        ----------
        motion : callable or None
            ``motion(t_s)`` with ``t_s`` the device time in seconds
            (:meth:`device_time_s`) gives the true target: shape (3,), mm,
            tracker frame, or (6,) with the probe's rotation vector, rad.
            Readings (``MEAS`` and stream ticks) show it at their stamp less
            :attr:`latency_s`. Re-acquires a broken beam, as :meth:`set_target`.
        """
        with self._lock:
            if motion is None:
                self._motion = None
                return
            self._set_target(*_split_pose(motion(self._device_s(self._clock()))))
            self._motion = motion

    def device_time_s(self) -> float:
        """The tracker's clock now, s (its readings carry it in microseconds)."""
        return self._device_s(self._clock())

    def _device_s(self, now: float) -> float:
        return now - self._t0

    def _pose_at(self, t_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """True point, rotation vector and noise scale for a reading stamped ``t_s`` (device s)."""
        if self._motion is None:
            return self._target, self._target_rotvec, self._noise_scale  # type: ignore[return-value]
        point, rot = _split_pose(self._motion(t_s - self.latency_s))
        scale = self.noise.scale_matrix(point) if np.linalg.norm(point) > 0 else None
        return point, (self._target_rotvec if rot is None else rot), scale

    def arm_fault(self, fault: Fault | str) -> None:
        """Arm one fault (a :class:`Fault` or a fault-script line)."""
        with self._lock:
            self._faults.arm(parse_fault(fault) if isinstance(fault, str) else fault)

    # ------------------------------------------------------------ wire

    def handle_line(self, line: bytes) -> list[LineOutput]:
        """Process one received line (with its ``\\r\\n``) and return what to send."""
        with self._lock:
            try:
                cmd = parse_command(decode_frame(line))
            except FrameError as exc:
                return [bad_frame_reply(line, exc)]
            if cmd.name == "SIM":
                return [Send(encode_frame(self._sim(cmd)))]
            faults = self._faults.next_command(cmd.name)
            pre: list[Output] = []
            body = None
            for fault in faults:
                if fault.kind == "not_initialised":
                    self.initialised = False
                elif fault.kind == "beam_break":
                    self._beam_broken_left = fault.count
                    pre.append(Send(encode_frame(error_body(EVENT_SEQ, ErrorCode.BEAM_BROKEN))))
                elif fault.kind == "unstable":
                    self._unstable_left = fault.count
                elif fault.kind == "inaccurate":
                    self._inaccurate_left = fault.count
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
        delay = self.init_time_s if cmd.name == "INIT" and frame.startswith(b"OK") else 0.0
        for fault in faults:
            if fault.kind == "drop":
                return []
            if fault.kind == "hangup":
                return [HangUp()]
            if fault.kind == "garble":
                # Line noise: printable junk without '*', so it cannot pass as a frame.
                junk = self._rng.integers(0x21, 0x7F, size=max(8, len(frame) - 2), dtype=np.uint8)
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
        now = self._clock()
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
        if now < self._busy_until:
            state = "BUSY"
        elif self.initialised and self._target is not None and not self._beam_broken_left:
            state = "READY"
        else:
            state = "NOT_READY"
        beam = int(self._target is not None and not self._beam_broken_left)
        probe = "P6" if self.probe_6dof else "P3"
        return ok_body(cmd.seq, state, int(self.initialised), beam, probe, self._mode)

    def _init(self, cmd, now, post):
        # The head moves; the OK is held back until it is done (see _deliver).
        self._busy_until = now + self.init_time_s
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
        on_s = self._on_s0 + (now - self._t0)
        air = (format_number(v, 2) for v in self.air)
        return ok_body(cmd.seq, *air, format_number(on_s, 1), int(on_s >= WARM_UP_S))

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
        if not self.initialised:
            return error_body(cmd.seq, ErrorCode.NOT_INITIALISED)
        if self._target is None:
            return error_body(cmd.seq, ErrorCode.NO_TARGET)
        if self._beam_broken_left:
            self._beam_broken_left -= 1
            if not self._beam_broken_left:  # the tracker re-locks on its own afterwards
                post.append(Send(encode_frame(error_body(EVENT_SEQ, ErrorCode.BEAM_RESTORED))))
            return error_body(cmd.seq, ErrorCode.BEAM_BROKEN)
        t_us = int((now - self._t0) * 1e6)
        if self._motion is not None:  # a moving target: where it was at the stamp
            return self._moving_reading(cmd.seq, t_us)
        if not MIN_RANGE_MM <= self._range_mm <= MAX_RANGE_MM:
            return error_body(cmd.seq, ErrorCode.OUT_OF_RANGE, f"{self._range_mm:.1f} mm")
        point = self.noise.sample_point(self._target, self._rng, self._noise_scale)
        point, status = self._flagged(point)
        rotvec = None
        if self.probe_6dof:
            rotvec = self.noise.sample_rotvec(self._target_rotvec, self._rng)
            rotvec = rotvec / ANGLE_UNITS[self._units[1]]
        point = point / LENGTH_UNITS[self._units[0]]
        return ok_body(cmd.seq, *reading_fields(point, rotvec, status, t_us))

    def _flagged(self, point: np.ndarray) -> tuple[np.ndarray, ReadingStatus]:
        """A reading's point and status under the scripted flag faults (consumes one)."""
        if self._unstable_left:
            self._unstable_left -= 1
            return point + self._rng.normal(0.0, UNSTABLE_SIGMA_MM, 3), ReadingStatus.UNSTABLE
        if self._inaccurate_left:
            self._inaccurate_left -= 1
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
        if self._target is None:
            return ("NONE", str(int(ErrorCode.NO_TARGET)))
        if self._beam_broken_left:
            self._beam_broken_left -= 1
            return ("NONE", str(int(ErrorCode.BEAM_BROKEN)))
        point, rot, scale = self._pose_at(t_us / 1e6)
        if not MIN_RANGE_MM <= float(np.linalg.norm(point)) <= MAX_RANGE_MM:
            return ("NONE", str(int(ErrorCode.OUT_OF_RANGE)))
        point = self.noise.sample_point(point, self._rng, scale)
        point, status = self._flagged(point)
        rotvec = None
        if self.probe_6dof:
            rotvec = self.noise.sample_rotvec(rot, self._rng) / ANGLE_UNITS[self._units[1]]
        point = point / LENGTH_UNITS[self._units[0]]
        return reading_fields(point, rotvec, status, t_us)[:-1]

    # ------------------------------------------------------------ streams

    def _stream(self, cmd, now, post):
        rate, count = parse_stream_rate(cmd.args)  # ValueError: BAD_PARAMETER
        if not self.initialised:
            return error_body(cmd.seq, ErrorCode.NOT_INITIALISED)
        post.append(StreamStart(cmd.seq, rate, count))
        return ok_body(cmd.seq, rate)

    def stream_tick(self, stream_id: int, n: int, stamp_s: float) -> list[LineOutput]:
        """Outputs of tick ``n`` of stream ``stream_id``, due at ``stamp_s`` (device time, s).

        The tick is stamped and measured at its due time on the tracker's
        clock (a server running late sends ticks late, never with a later
        position), and the fault script's ``SAMPLE`` triggers count ticks.
        """
        with self._lock:
            t_us = max(int(round(stamp_s * 1e6)), 0)
            faults = self._faults.next_command("SAMPLE", count_any=False)
            pre: list[Output] = []
            error = None
            for fault in faults:
                if fault.kind == "stall":
                    return [StreamStall(fault.delay_s)]
                if fault.kind == "beam_break":
                    self._beam_broken_left = fault.count
                    pre.append(Send(encode_frame(error_body(EVENT_SEQ, ErrorCode.BEAM_BROKEN))))
                elif fault.kind == "unstable":
                    self._unstable_left = fault.count
                elif fault.kind == "inaccurate":
                    self._inaccurate_left = fault.count
                elif fault.kind == "error":
                    error = fault.code
            was_broken = self._beam_broken_left > 0
            if error is not None:
                fields: tuple[str, ...] = ("NONE", str(int(error)))
            else:
                fields = self._tick_fields(t_us)
            body = stream_body(stream_id, n, *fields, str(t_us))
            post: list[LineOutput] = []
            if was_broken and not self._beam_broken_left:  # re-locked after this tick
                post.append(Send(encode_frame(error_body(EVENT_SEQ, ErrorCode.BEAM_RESTORED))))
            tick = Command(0, "SAMPLE", ())
            return [*pre, *self._deliver(encode_frame(body), faults, tick), *post]

    def stream_end(self, stream_id: int, n: int) -> bytes:
        """The end frame of a stream whose last tick was ``n``."""
        with self._lock:
            t_us = int((self._clock() - self._t0) * 1e6)
            return encode_frame(stream_body(stream_id, max(n, 1), "END", str(t_us)))

    def _sim(self, cmd: Command) -> str:
        """Simulator-only commands: SIM,TARGET / SIM,NOTARGET / SIM,FAULT."""
        try:
            what, *args = cmd.args
            if what == "TARGET" and len(args) in (3, 6):
                values = [parse_number(a) for a in args]
                self._set_target(values[:3], values[3:] or None)
                self._motion = None  # a fixed target from now on
            elif what == "NOTARGET" and not args:
                self._target = None
                self._motion = None
            elif what == "PATH" and args:
                return self._sim_path(cmd.seq, args)
            elif what == "FAULT" and len(args) == 1:
                self._faults.arm(parse_fault(args[0]))
            else:
                return error_body(cmd.seq, ErrorCode.UNKNOWN_COMMAND, "SIM," + what)
        except ValueError as exc:
            return error_body(cmd.seq, ErrorCode.BAD_PARAMETER, str(exc))
        return ok_body(cmd.seq)

    def _sim_path(self, seq: int, args: list[str]) -> str:
        """``SIM,PATH,CLEAR`` / ``SIM,PATH,POINT,t,x,y,z[,rx,ry,rz]`` / ``SIM,PATH,GO[,delay]``.

        Waypoints (time from the path's start, s; mm and rad) are collected,
        then ``GO`` moves the target through them, linear in between, from
        ``delay`` seconds after now on the device clock; the ``OK`` carries that
        start in microseconds. Before the start and after the end it holds.
        """
        what, rest = args[0], args[1:]
        if what == "CLEAR" and not rest:
            self._waypoints = []
            return ok_body(seq)
        if what == "POINT" and len(rest) in (4, 7):
            values = [parse_number(a) for a in rest]
            if self._waypoints and values[0] <= self._waypoints[-1][0]:
                raise ValueError(f"waypoint time {values[0]} s does not increase")
            if len(self._waypoints) >= MAX_WAYPOINTS:
                raise ValueError(f"more than {MAX_WAYPOINTS} waypoints")
            if self._waypoints and len(values) != len(self._waypoints[-1]):
                raise ValueError("waypoints mix positions with and without orientation")
            self._waypoints.append(values)
            return ok_body(seq)
        if what == "GO" and len(rest) <= 1 and self._waypoints:
            delay = parse_number(rest[0]) if rest else 0.0
            if not 0.0 <= delay <= 3600.0:
                raise ValueError(f"start delay {delay} s outside 0..3600")
            table = np.array(self._waypoints)
            start = self._device_s(self._clock()) + delay

            def motion(t_s: float) -> np.ndarray:
                return np.array(
                    [np.interp(t_s - start, table[:, 0], col) for col in table[:, 1:].T]
                )

            self._set_target(*_split_pose(motion(self._device_s(self._clock()))))
            self._motion = motion
            return ok_body(seq, int(start * 1e6))
        return error_body(seq, ErrorCode.UNKNOWN_COMMAND, "SIM,PATH," + what)


def _split_pose(values: ArrayLike) -> tuple[np.ndarray, np.ndarray | None]:
    """``(point (3,), rotvec (3,) or None)`` from 3 or 6 values; finite, else ValueError."""
    v = np.asarray(values, dtype=float).ravel()
    if v.shape not in ((3,), (6,)) or not np.all(np.isfinite(v)):
        raise ValueError(f"a target is 3 or 6 finite values, got {v.shape}")
    return v[:3], (v[3:] if len(v) == 6 else None)


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
