"""One emScon command at a time over a TCP socket, each bounded by a deadline.

emScon packets carry no sequence number, so a reply is matched by what it is:
the command reply (or ``ES_DT_Error``) must name our command, and a
``SingleMeasResult`` is only accepted while our ``StartMeasurement`` is the
one command in flight. After a timeout the link is *unsettled*: a late answer
to the abandoned command may still arrive. The next transaction first sends a
cheap fence (``GetTrackerStatus``) and discards everything before the fence's
*successful* reply: the server works through its queue in order, so an OK
answer to the fence comes after anything the abandoned command still had to
say. A server that is still busy with the abandoned measurement answers the
fence at once with ``ES_RS_ServerBusy``, out of order; such an answer proves
nothing, so the fence is sent again (every ``busy_poll_s``) until an OK reply
or the deadline. A fence refused with any other status raises that error and
the link stays unsettled. A packet that breaks the framing (size disagreeing
with its type), or one that starts and then stops arriving for longer than
``packet_gap_s``, makes the stream untrustworthy: the link is then marked
broken and the caller reconnects. Packets of the types Leica's header defines
but this adapter does not use (6-DoF and extended continuous results, probe
position results) are skipped by their validated size, as are continuous
results that arrive while a command waits for its reply;
:meth:`EmsconLink.read_stream_packet` reads a running continuous measurement.
"""

from __future__ import annotations

import socket
import time
from collections import deque
from collections.abc import Callable
from typing import Literal, overload

from drivers.tracker.emscon import protocol as pk
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
    events : deque
        Where ``SystemStatusChange`` events go (the adapter's, so they survive
        reconnects).
    packet_gap_s : float
        Longest silence inside one packet (its first bytes arrived), s: past it
        the framing is lost and the link is broken.
    busy_poll_s : float
        Pause before the fence is sent again after an ``ES_RS_ServerBusy`` answer, s.
    clock : callable
        Monotonic clock, s.
    """

    def __init__(
        self,
        sock: socket.socket,
        *,
        events: deque,
        packet_gap_s: float,
        busy_poll_s: float = 0.05,
        clock: Callable[[], float] = time.monotonic,
    ):
        self.sock = sock
        self.events = events
        self.stale = 0  # packets dropped because they answered another (earlier) command
        self.broken = False  # framing lost or transport failed: reconnect before use
        self._unsettled = False  # a command timed out: fence before the next one
        self.packet_gap_s = packet_gap_s
        self.busy_poll_s = busy_poll_s
        self.fence_busy = 0  # fences answered ES_RS_ServerBusy (diagnostics)
        # Continuous results that arrived while a command waited for its reply (e.g.
        # between StopMeasurement and its answer): never taken for a reading.
        self.stream_packets_dropped = 0
        self._clock = clock
        self._buf = bytearray()
        self._last_byte = 0.0  # when the last bytes arrived (silence inside a packet)

    def close(self) -> None:
        try:
            self.sock.close()
        except OSError:
            pass  # already gone

    # ------------------------------------------------------------ transactions

    @overload
    def transact(
        self, command: int, params: bytes = ..., *, timeout_s: float, measure: Literal[False] = ...
    ) -> pk.CommandReply: ...

    @overload
    def transact(
        self, command: int, params: bytes = ..., *, timeout_s: float, measure: Literal[True]
    ) -> pk.MeasResult: ...

    @overload
    def transact(
        self, command: int, params: bytes = ..., *, timeout_s: float, measure: bool
    ) -> pk.CommandReply | pk.MeasResult: ...

    def transact(
        self, command: int, params: bytes = b"", *, timeout_s: float, measure: bool = False
    ) -> pk.CommandReply | pk.MeasResult:
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
            if self._buf or self.broken:
                # Part of a packet is pending: if its size field lied, every later packet
                # would be cut in the wrong place. Only a new connection is certain.
                self._lose_framing()
            else:
                self._unsettled = True
            raise

    def _fence(self, deadline: float, name: str) -> None:
        """Discard everything up to an OK reply to a fresh ``GetTrackerStatus``.

        Raises
        ------
        TrackerTimeout
            The server stayed busy (or silent) until the deadline.
        TrackerError
            The fence was refused with a status other than busy.
        """
        fence = pk.Command.GET_TRACKER_STATUS
        self._send(pk.encode_command(fence))
        while True:
            packet = self._next_packet(deadline, name)
            if not isinstance(packet, pk.CommandReply | pk.ErrorResponse):
                self._note_other(packet)
                continue
            if packet.command != fence:
                self._note_other(packet)
                continue
            if packet.status == pk.ResultStatus.ALL_OK and isinstance(packet, pk.CommandReply):
                self._unsettled = False
                return
            if packet.status != pk.ResultStatus.SERVER_BUSY:
                raise error_for_status(packet.status, _name(fence), f"fence before {name}")
            # Busy with the abandoned command: its answer is still to come. Ask again.
            self.fence_busy += 1
            pause = min(self.busy_poll_s, deadline - self._clock())
            if pause > 0:
                time.sleep(pause)
            self._send(pk.encode_command(fence))

    def _await(
        self, command: int, deadline: float, name: str, measure: bool
    ) -> pk.CommandReply | pk.MeasResult:
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
            if measure and isinstance(packet, pk.SingleMeasResult | pk.ProbeStationaryResult):
                if packet.status != pk.ResultStatus.ALL_OK:
                    raise error_for_status(packet.status, name)
                return packet
            self._note_other(packet)

    def _note_other(self, packet: pk.Packet) -> None:
        if isinstance(packet, pk.StatusChangeEvent):
            self.events.append(packet)
        else:
            self.stale += 1
            if isinstance(packet, pk.MultiMeasResult):
                self.stream_packets_dropped += 1

    def read_stream_packet(
        self, deadline: float
    ) -> pk.MultiMeasResult | pk.ErrorResponse | pk.StatusChangeEvent:
        """The next packet a running continuous measurement sends, by ``deadline``.

        Continuous results, ``ES_DT_Error`` packets (how the server reports a
        measurement that cannot go on) and status changes (also kept in
        :attr:`events`) are returned; stray command replies are counted stale.

        Raises
        ------
        TrackerTimeout
            Nothing by the deadline (the link fences before its next command; a
            packet cut short breaks it).
        FrameError, ConnectionLost
            As for :meth:`transact` (link now broken).
        """
        name = "continuous results"
        try:
            while True:
                packet = self._next_packet(deadline, name)
                if isinstance(packet, pk.StatusChangeEvent):
                    self.events.append(packet)
                    return packet
                if isinstance(packet, pk.MultiMeasResult | pk.ErrorResponse):
                    return packet
                self.stale += 1
        except TrackerTimeout:
            if self._buf or self.broken:
                self._lose_framing()
            else:
                self._unsettled = True
            raise

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
            now = self._clock()
            remaining = deadline - now
            if self._buf:  # inside a packet: the rest must not stall
                gap_left = self._last_byte + self.packet_gap_s - now
                if gap_left <= 0:
                    self._lose_framing()
                    raise TrackerTimeout(
                        f"a packet stopped arriving while waiting for {name} "
                        f"(no byte for {self.packet_gap_s:g} s); the stream cannot be re-cut"
                    )
                remaining = min(remaining, gap_left)
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
            self._last_byte = self._clock()
            self._buf += chunk


def _name(command: int) -> str:
    try:
        return "ES_C_" + pk.Command(command).name
    except ValueError:
        return f"ES_C_{command}"
