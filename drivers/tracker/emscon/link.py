"""One emScon command at a time over a TCP socket, each bounded by a deadline.

emScon packets carry no sequence number, so a reply is matched by what it is:
the command reply (or ``ES_DT_Error``) must name our command, and a
``SingleMeasResult`` is only accepted while our ``StartMeasurement`` is the
one command in flight. After a timeout the link is *unsettled*: a late answer
to the abandoned command may still arrive. Because the server answers in
command order, the next transaction first sends a cheap fence
(``GetTrackerStatus``) and discards everything before the fence's reply, so
a late reading can never be taken for the answer to a later command. A packet
that breaks the framing (size disagreeing with its type) makes the stream
untrustworthy: the link is then marked broken and the caller reconnects.
"""

from __future__ import annotations

import socket
import time
from collections import deque
from collections.abc import Callable

from drivers.tracker.emscon import packets as pk
from drivers.tracker.emscon.errors import (
    ConnectionLost,
    FrameError,
    TrackerTimeout,
    error_for_status,
)


class EmsconLink:
    """Deadline-bounded transactions on one connected socket.

    Parameters
    ----------
    sock : socket.socket
        Connected TCP socket (the link owns it from now on).
    events : deque, optional
        Where ``SystemStatusChange`` events go (survives reconnects if shared).
    on_event : callable, optional
        Called with each :class:`~drivers.tracker.emscon.packets.StatusChangeEvent`.
    clock : callable
        Monotonic clock, s.
    """

    def __init__(
        self,
        sock: socket.socket,
        *,
        events: deque | None = None,
        on_event: Callable[[pk.StatusChangeEvent], None] | None = None,
        clock: Callable[[], float] = time.monotonic,
    ):
        self.sock = sock
        self.events: deque = deque(maxlen=256) if events is None else events
        self.on_event = on_event
        self.stale = 0  # packets dropped because they answered another (earlier) command
        self.broken = False  # framing lost or transport failed: reconnect before use
        self._unsettled = False  # a command timed out: fence before the next one
        self._clock = clock
        self._buf = bytearray()

    def close(self) -> None:
        try:
            self.sock.close()
        except OSError:
            pass  # already gone

    # ------------------------------------------------------------ transactions

    def transact(
        self, command: int, params: bytes = b"", *, timeout_s: float, measure: bool = False
    ) -> pk.CommandReply | pk.SingleMeasResult:
        """Send ``command`` and return its OK reply (or, with ``measure``, its result).

        Raises
        ------
        TrackerTimeout
            No answer by the deadline (the link fences before its next command).
        FrameError
            A packet broke the framing or disagreed with its type (link now broken).
        TrackerError
            The server refused (typed by ``ES_ResultStatus``).
        ConnectionLost
            The transport failed (link now broken).
        """
        deadline = self._clock() + timeout_s
        name = _name(command)
        try:
            if self._unsettled:
                self._fence(deadline, name)
            self._send(pk.encode_command(command, params))
            return self._await(command, deadline, name, measure)
        except TrackerTimeout:
            if self._buf:
                # Part of a packet is pending: if its size field lied, every later packet
                # would be cut in the wrong place. Only a new connection is certain.
                self._lose_framing()
            else:
                self._unsettled = True
            raise

    def _fence(self, deadline: float, name: str) -> None:
        """Discard everything up to the reply to a fresh ``GetTrackerStatus``."""
        fence = pk.Command.GET_TRACKER_STATUS
        self._send(pk.encode_command(fence))
        while True:
            packet = self._next_packet(deadline, name)
            if isinstance(packet, pk.CommandReply | pk.ErrorResponse) and packet.command == fence:
                self._unsettled = False
                return
            self._note_other(packet)

    def _await(self, command: int, deadline: float, name: str, measure: bool):
        while True:
            packet = self._next_packet(deadline, name)
            if isinstance(packet, pk.CommandReply | pk.ErrorResponse) and packet.command == command:
                if packet.status != pk.ResultStatus.ALL_OK:
                    raise error_for_status(packet.status, name)
                if isinstance(packet, pk.ErrorResponse):
                    raise FrameError(f"ES_DT_Error with status 0 for {name}")
                if not measure:
                    return packet
                continue  # StartMeasurement acknowledged; the result follows
            if measure and isinstance(packet, pk.SingleMeasResult):
                if packet.status != pk.ResultStatus.ALL_OK:
                    raise error_for_status(packet.status, name)
                return packet
            self._note_other(packet)

    def _note_other(self, packet: pk.Packet) -> None:
        if isinstance(packet, pk.StatusChangeEvent):
            self.events.append(packet)
            if self.on_event is not None:
                self.on_event(packet)
        else:
            self.stale += 1

    # ------------------------------------------------------------ bytes

    def _send(self, data: bytes) -> None:
        if self.broken:
            raise ConnectionLost("emScon link is broken: reconnect first")
        try:
            self.sock.sendall(data)
        except OSError as exc:
            self.broken = True
            raise ConnectionLost(f"emScon connection failed while sending: {exc}") from exc

    def _next_packet(self, deadline: float, name: str) -> pk.Packet:
        self._fill(pk.HEADER.size, deadline, name)
        try:
            size, _ = pk.split_header(self._buf)
        except pk.PacketSizeError as exc:
            self._lose_framing()
            raise FrameError(f"while waiting for {name}: {exc}") from exc
        self._fill(size, deadline, name)
        data = bytes(self._buf[:size])
        del self._buf[:size]
        try:
            return pk.decode_server_packet(data)
        except ValueError as exc:  # includes PacketSizeError
            # The size field and the type disagree: neither can be trusted, nor what follows.
            self._lose_framing()
            raise FrameError(f"while waiting for {name}: {exc}") from exc

    def _lose_framing(self) -> None:
        self.broken = True
        self._buf.clear()

    def _fill(self, n: int, deadline: float, name: str) -> None:
        while len(self._buf) < n:
            remaining = deadline - self._clock()
            if remaining <= 0:
                raise TrackerTimeout(
                    f"no answer to {name} within the deadline ({len(self._buf)} bytes pending)"
                )
            try:
                self.sock.settimeout(remaining)
                chunk = self.sock.recv(65536)
            except TimeoutError:
                continue  # the loop reports the timeout
            except OSError as exc:
                self.broken = True
                raise ConnectionLost(f"emScon connection failed while reading: {exc}") from exc
            if not chunk:
                self.broken = True
                raise ConnectionLost(f"emScon server closed the connection during {name}")
            self._buf += chunk


def _name(command: int) -> str:
    try:
        return "ES_C_" + pk.Command(command).name
    except ValueError:
        return f"ES_C_{command}"
