"""One request/reply transaction at a time over a serial-like transport.

The link frames a command with the next sequence number, writes it, and
reads lines until the reply with that sequence number arrives or the
deadline passes. Stale replies (other sequence numbers, e.g. the late
answer to a command that timed out) are dropped; ``EV`` frames are kept in
:attr:`Link.events`. Bytes of an incomplete line stay buffered for the
next read. Transport failures become :class:`ConnectionLost`.
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable
from typing import Protocol

import serial

from drivers.tracker.errors import ConnectionLost, FrameError, TrackerTimeout
from drivers.tracker.protocol import (
    MAX_FRAME,
    TERMINATOR,
    Reply,
    ReplyKind,
    command_body,
    decode_frame,
    encode_frame,
    error_from_reply,
    next_seq,
    parse_reply,
)
from drivers.tracker.recording import Recorder


class SerialLike(Protocol):
    """The part of ``serial.Serial`` the driver uses."""

    timeout: float | None

    @property
    def in_waiting(self) -> int: ...
    def read(self, size: int = ...) -> bytes: ...
    def write(self, data: bytes) -> int | None: ...
    def read_until(self, expected: bytes = ..., size: int | None = ...) -> bytes: ...
    def reset_input_buffer(self) -> None: ...
    def close(self) -> None: ...


# pyserial raises SerialException (an IOError) or plain OSError when a port vanishes.
TRANSPORT_ERRORS = (serial.SerialException, OSError)


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
        clock: Callable[[], float] = time.monotonic,
    ):
        self.port = port
        self.recorder = recorder
        self.on_event = on_event
        self.events: deque[Reply] = deque(maxlen=256) if events is None else events
        self.stale_replies = 0  # replies dropped for a wrong sequence number
        self._clock = clock
        self._seq = 0
        self._buf = bytearray()

    @property
    def last_seq(self) -> int:
        """Sequence number of the last command sent (0 before the first)."""
        return self._seq

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
            No reply with our sequence number by the deadline.
        FrameError, ChecksumError
            A line arrived that is not a valid frame (raised at once).
        TrackerError
            The tracker answered ``ER`` (typed by code, see ``protocol.error_from_reply``).
        ConnectionLost
            The transport failed.
        """
        self._seq = next_seq(self._seq)
        seq = self._seq
        frame = encode_frame(command_body(seq, command, *args))
        deadline = self._clock() + timeout_s
        self._write(frame)
        while True:
            line = self._read_line(deadline, command)
            reply = parse_reply(decode_frame(line))
            if reply.kind is ReplyKind.EV:
                self.events.append(reply)
                if self.on_event is not None:
                    self.on_event(reply)
                continue
            if reply.seq != seq:
                self.stale_replies += 1
                continue
            if reply.kind is ReplyKind.ER:
                raise error_from_reply(reply, command)
            return reply

    def discard_input(self) -> None:
        """Forget buffered bytes and anything waiting in the transport (after a reconnect)."""
        self._buf.clear()
        try:
            self.port.reset_input_buffer()
        except TRANSPORT_ERRORS as exc:
            raise ConnectionLost(f"transport failed: {exc}") from exc

    def _write(self, frame: bytes) -> None:
        if self.recorder is not None:
            self.recorder.log("tx", frame)
        try:
            self.port.write(frame)
        except TRANSPORT_ERRORS as exc:
            raise ConnectionLost(f"transport failed while writing: {exc}") from exc

    def _read_line(self, deadline: float, command: str) -> bytes:
        """Next complete line (with ``\\r\\n``) by ``deadline``; partial bytes stay buffered."""
        while True:
            end = self._buf.find(TERMINATOR)
            if end >= 0:
                line = bytes(self._buf[: end + 2])
                del self._buf[: end + 2]
                return line
            if len(self._buf) >= MAX_FRAME:
                junk = bytes(self._buf[:60])
                self._buf.clear()
                raise FrameError(f"no line end within {MAX_FRAME} bytes: {junk!r}")
            remaining = deadline - self._clock()
            if remaining <= 0:
                raise TrackerTimeout(
                    f"no reply to {command} within the deadline ({len(self._buf)} bytes pending)"
                )
            self._buf += self._read_chunk(remaining)

    def _read_chunk(self, remaining: float) -> bytes:
        port = self.port
        room = MAX_FRAME - len(self._buf)
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
            elif not self._buf:
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
