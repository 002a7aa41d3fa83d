"""One request/reply transaction at a time over a serial-like transport.

The link frames a command with the next sequence number, writes it, and
reads lines until the reply with that sequence number arrives or the
deadline passes. Stale replies (other sequence numbers, e.g. the late
answer to a command that timed out) are dropped and counted; ``EV`` frames
are kept in :attr:`Link.events`. Bytes of an incomplete line stay buffered
for the next read. Transport failures become :class:`ConnectionLost`.

Why a reading always belongs to its command:

- The sequence counter lives in :class:`LinkCounters`, which the driver
  keeps across reconnects, so a late reply to a command sent before a
  reconnect never carries the number of a command sent after it (numbers
  repeat only after :data:`~drivers.tracker.line.protocol.SEQ_MAX` commands).
- A line longer than a frame is not kept: only its last bytes are, and when
  its line end comes a valid frame is looked for at their end (junk glued
  to the front of a reply). Memory stays bounded against an endless line.
- Writes are bounded by the deadline too (``write_timeout``), so a device
  that stops reading cannot block a call.
"""

from __future__ import annotations

import contextlib
import socket
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import serial

from drivers.tracker.errors import ConnectionLost, FrameError, TrackerTimeout
from drivers.tracker.line.errors import error_from_reply
from drivers.tracker.line.protocol import (
    MAX_FRAME,
    TERMINATOR,
    Reply,
    ReplyKind,
    StreamFrame,
    command_body,
    decode_frame,
    encode_frame,
    is_stream_body,
    next_seq,
    parse_command,
    parse_reply,
    parse_stream_frame,
)
from drivers.tracker.recording import Recorder


class SerialLike(Protocol):
    """The part of ``serial.Serial`` the driver uses."""

    timeout: float | None
    write_timeout: float | None

    @property
    def in_waiting(self) -> int: ...
    def read(self, size: int = ...) -> bytes: ...
    def write(self, data: bytes) -> int | None: ...
    def read_until(self, expected: bytes = ..., size: int | None = ...) -> bytes: ...
    def reset_input_buffer(self) -> None: ...
    def close(self) -> None: ...


# pyserial raises SerialException (an IOError) or plain OSError when a port vanishes.
TRANSPORT_ERRORS = (serial.SerialException, OSError)


def close_for_good(port: SerialLike) -> None:
    """Close a transport that will not be reopened; a ``socket://`` one without a pause.

    pyserial's socket transport sleeps 0.3 s in ``close()`` so that a quick
    reconnect finds the server ready again. A link closed for good (the
    simulator's control link at the end of a run) has no reconnect to wait
    for, so its socket is shut down and closed directly.
    """
    sock = getattr(port, "_socket", None)
    if isinstance(sock, socket.socket):
        with contextlib.suppress(OSError):  # the peer may have gone first
            sock.shutdown(socket.SHUT_RDWR)
        sock.close()
        port._socket = None  # type: ignore[attr-defined]  # what pyserial's close() resets
        port.is_open = False  # type: ignore[attr-defined]
        return
    port.close()


# Start of every tracker frame: where a reply glued behind junk may begin.
_FRAME_STARTS = (b"OK,", b"ER,", b"EV,")
# Bytes taken per read while an over-long line is being skipped (only its tail is kept).
_SKIP_CHUNK = 65536


@dataclass
class LinkCounters:
    """State that outlives one :class:`Link`: one per driver, kept across reconnects.

    Attributes
    ----------
    seq : int
        Sequence number of the last command sent (0 before the first).
    stale_replies : int
        Replies dropped because they answered another command (late replies).
    discarded_bytes : int
        Received bytes thrown away: junk before a frame, over-long lines,
        input flushed at a reconnect.
    stream_frames_dropped : int
        Valid stream frames not handed over: of another (earlier) stream, a
        tick number that does not move forward, or arriving while a command
        waits for its reply (after ``STOP``).
    bad_stream_lines : int
        Lines read while streaming that were not valid frames (bad CRC,
        garbled, over-long): each a lost tick, never a reading.
    """

    seq: int = 0
    stale_replies: int = 0
    discarded_bytes: int = 0
    stream_frames_dropped: int = 0
    bad_stream_lines: int = 0


class Link:
    """Sequenced transactions on one open transport.

    Parameters
    ----------
    port : SerialLike
        An open transport (``serial.serial_for_url(...)`` or a test fake).
    recorder : Recorder, optional
        Receives every written frame and every chunk read.
    on_event : callable, optional
        Called with each ``EV`` :class:`Reply` as it arrives.
    events : deque, optional
        Where to keep events (lets them outlive a reconnect); a new one by default.
    counters : LinkCounters, optional
        Sequence counter and statistics; pass the same object to the link
        that replaces this one after a reconnect (a new one by default).
    clock : callable
        Monotonic clock in seconds (deadlines).
    """

    def __init__(
        self,
        port: SerialLike,
        *,
        recorder: Recorder | None = None,
        on_event: Callable[[Reply], None] | None = None,
        events: deque[Reply] | None = None,
        counters: LinkCounters | None = None,
        clock: Callable[[], float] = time.monotonic,
    ):
        self.port = port
        self.recorder = recorder
        self.on_event = on_event
        self.events: deque[Reply] = deque(maxlen=256) if events is None else events
        self.counters = LinkCounters() if counters is None else counters
        self._clock = clock
        self._buf = bytearray()
        self._skipping = False  # inside a line longer than a frame: keep only its tail
        self._skipped_line = False  # the last line returned was the tail of such a line
        self._unterminated_write = False  # a write timed out part-way through a frame
        self._write_timeout_works = True

    @property
    def last_seq(self) -> int:
        """Sequence number of the last command sent (0 before the first)."""
        return self.counters.seq

    @property
    def stale_replies(self) -> int:
        """Replies dropped because they answered another command (across reconnects)."""
        return self.counters.stale_replies

    def transact(self, command: str, *args: str, timeout_s: float) -> Reply:
        """Send one command and return its ``OK`` reply.

        Parameters
        ----------
        command : str
            Command name, e.g. ``"MEAS"``.
        *args : str
            Already formatted argument fields.
        timeout_s : float
            Deadline for the complete reply line, seconds from now.

        Raises
        ------
        TrackerTimeout
            The frame could not be written, or no reply with our sequence
            number arrived, by the deadline.
        FrameError, ChecksumError
            A line arrived that is not a valid frame (raised at once).
        TrackerError
            The tracker answered ``ER`` (typed by code, see ``errors.error_from_reply``).
        ConnectionLost
            The transport failed.
        """
        counters = self.counters
        counters.seq = seq = next_seq(counters.seq)
        frame = encode_frame(command_body(seq, command, *args))
        deadline = self._clock() + timeout_s
        self._write(frame, deadline, command)
        while True:
            body = self._decode(self._read_line(deadline, command))
            if body is None:
                continue
            if is_stream_body(body):
                counters.stream_frames_dropped += 1  # a stream's tick, not this reply
                continue
            try:
                reply = parse_reply(body)
            except FrameError:
                if not _is_host_frame(body):
                    raise
                counters.stale_replies += 1  # our own frame echoed back: not a reply
                continue
            if reply.kind is ReplyKind.EV:
                self.events.append(reply)
                if self.on_event is not None:
                    self.on_event(reply)
                continue
            if reply.seq != seq:
                counters.stale_replies += 1
                continue
            if reply.kind is ReplyKind.ER:
                raise error_from_reply(reply, command)
            return reply

    def read_stream_frame(self, stream_id: int, deadline: float) -> StreamFrame:
        """The next frame of stream ``stream_id``, read by ``deadline`` (no command sent).

        Events are kept as in :meth:`transact`; replies (no command waits) and
        frames of other streams are dropped and counted; a line that is not a
        valid frame is counted in ``bad_stream_lines`` and skipped, so a
        corrupted tick is lost, never passed on.

        Raises
        ------
        TrackerTimeout
            No frame of this stream by the deadline.
        ConnectionLost
            The transport failed.
        """
        counters = self.counters
        while True:
            try:
                body = self._decode(self._read_line(deadline, "STREAM"))
                if body is None:
                    continue
                if is_stream_body(body):
                    frame = parse_stream_frame(body)
                    if frame.stream_id == stream_id:
                        return frame
                    counters.stream_frames_dropped += 1
                    continue
                reply = parse_reply(body)
            except FrameError:
                counters.bad_stream_lines += 1
                continue
            if reply.kind is ReplyKind.EV:
                self.events.append(reply)
                if self.on_event is not None:
                    self.on_event(reply)
            else:
                counters.stale_replies += 1  # no command is waiting for it

    def discard_input(self) -> None:
        """Forget buffered bytes and anything waiting in the transport (after a reconnect)."""
        self.counters.discarded_bytes += len(self._buf)
        self._buf.clear()
        self._skipping = False
        try:
            self.counters.discarded_bytes += self.port.in_waiting
            self.port.reset_input_buffer()
        except TRANSPORT_ERRORS as exc:
            raise ConnectionLost(f"transport failed: {exc}") from exc

    def _write(self, frame: bytes, deadline: float, command: str) -> None:
        if self._unterminated_write:
            # The device holds the start of a frame we could not finish: end that line
            # first, so it answers BAD_FRAME to it instead of to this command.
            frame = TERMINATOR + frame
        if self.recorder is not None:
            self.recorder.log("tx", frame)
        port = self.port
        try:
            if self._write_timeout_works:
                self._bound_write(deadline)
            written = port.write(frame)
        except serial.SerialTimeoutException as exc:
            self._write_cut_short()
            raise TrackerTimeout(
                f"could not send {command} within the deadline: the device is not reading"
            ) from exc
        except TRANSPORT_ERRORS as exc:
            raise ConnectionLost(f"transport failed while writing: {exc}") from exc
        if written is not None and written < len(frame):
            # A zero write timeout (deadline already past) makes pyserial write what fits.
            self._write_cut_short()
            raise TrackerTimeout(f"could not send {command} within the deadline (partial write)")
        self._unterminated_write = False

    def _write_cut_short(self) -> None:
        """A frame went out in part: drop what is still queued, end that line next time."""
        self._unterminated_write = True
        reset = getattr(self.port, "reset_output_buffer", None)
        if reset is not None:
            try:
                reset()
            except TRANSPORT_ERRORS:
                pass  # the next write reports a vanished port

    def _bound_write(self, deadline: float) -> None:
        """Make the port's write give up at ``deadline``."""
        port = self.port
        remaining = max(deadline - self._clock(), 0.0)
        # Like the read timeout: only touch it (a tty syscall) when it is too long for
        # this deadline or far too short.
        current = getattr(port, "write_timeout", None)
        if current is None or current > remaining or current < 0.5 * remaining:
            try:
                port.write_timeout = remaining
            except NotImplementedError:
                # pyserial's rfc2217 client has no write timeout (and keeps the value it
                # refused, which breaks every later reconfiguration: take it back).
                # Its TCP send buffer must fill (megabytes) before a write can block.
                port.write_timeout = None
                self._write_timeout_works = False

    def _decode(self, line: bytes) -> str | None:
        """Body of the frame in ``line``, or of a valid frame at its end (after junk).

        Junk in front of a frame (line noise, the tail of an over-long line) is
        discarded and counted. A line with no valid frame raises as
        ``decode_frame``, except the end of an over-long line (its error was
        raised when it overflowed): that gives None.
        """
        try:
            return decode_frame(line)
        except FrameError:
            for start in _frame_starts(line):
                try:
                    body = decode_frame(line[start:])
                except FrameError:
                    continue
                self.counters.discarded_bytes += start
                return body
            self.counters.discarded_bytes += len(line)
            if self._skipped_line:
                return None
            raise

    def _read_line(self, deadline: float, command: str) -> bytes:
        """Next complete line (with ``\\r\\n``) by ``deadline``; partial bytes stay buffered.

        Of a line longer than a frame only the last ``MAX_FRAME`` bytes are
        kept (the rest is discarded as it arrives), so memory stays bounded
        and a reply glued to the end of junk can still be read.
        """
        buf = self._buf
        while True:
            end = buf.find(TERMINATOR)
            if end >= 0:
                line = bytes(buf[: end + 2])
                del buf[: end + 2]
                self._skipped_line, self._skipping = self._skipping, False
                return line
            if len(buf) >= MAX_FRAME:  # no frame is this long without its line end
                if not self._skipping:
                    self._skipping = True  # from now on keep only the tail of this line
                    raise FrameError(f"no line end within {MAX_FRAME} bytes: {bytes(buf[:60])!r}")
                excess = len(buf) - MAX_FRAME
                self.counters.discarded_bytes += excess
                del buf[:excess]
            remaining = deadline - self._clock()
            if remaining <= 0:
                skipping = ", skipping a line with no end" if self._skipping else ""
                raise TrackerTimeout(
                    f"no reply to {command} within the deadline "
                    f"({len(buf)} bytes pending{skipping})"
                )
            buf += self._read_chunk(remaining)

    def _read_chunk(self, remaining: float) -> bytes:
        port = self.port
        room = _SKIP_CHUNK if self._skipping else max(MAX_FRAME + 1 - len(self._buf), 1)
        try:
            # Changing the timeout reconfigures a tty (a syscall): only shrink it to the
            # deadline, or grow it when it is far too short for the time left.
            current = port.timeout
            if current is None or current > remaining or current < 0.5 * remaining:
                port.timeout = remaining
            # pyserial's read_until reads one byte per call, which alone would cap us
            # near 1000 readings/s; so take what is already waiting in one read, and
            # wait for a reply to begin with read(1). Both honour the port timeout.
            waiting = port.in_waiting
            if waiting > 1:
                chunk = port.read(min(waiting, room))
            elif waiting == 1 and self._buf:
                # socket:// only reports 0/1 ("readable"); a zero timeout makes one read
                # return everything that has arrived without waiting for more.
                port.timeout = 0
                chunk = port.read(room)
            elif not self._buf or self._skipping:
                # Skipping a line with no end: read_until would take it byte by byte.
                chunk = port.read(1)
            else:
                # A line has begun: finish it with read_until, bounded by the deadline.
                # A CR already buffered means the LF alone ends the line.
                expected = b"\n" if self._buf.endswith(b"\r") else TERMINATOR
                chunk = port.read_until(expected, room)
        except TRANSPORT_ERRORS as exc:
            raise ConnectionLost(f"transport failed while reading: {exc}") from exc
        if chunk and self.recorder is not None:
            self.recorder.log("rx", chunk)
        return chunk


def _frame_starts(line: bytes) -> list[int]:
    """Offsets after 0 where a tracker frame could begin in ``line``, in order."""
    found = []
    for tag in _FRAME_STARTS:
        at = line.find(tag, 1)
        while at >= 0:
            found.append(at)
            at = line.find(tag, at + 1)
    return sorted(found)


def _is_host_frame(body: str) -> bool:
    """Whether a valid frame is a host command (an echo), not a garbled reply."""
    try:
        parse_command(body)
    except FrameError:
        return False
    return True
