"""Serve an :class:`EmsconSimulator` on loopback TCP: the emScon port and a control port.

The emScon port frames packets by their ``lPacketSize`` and answers each
connection in command order (a connection's thread sleeps through a delayed
answer, as a real server works through its command queue). The control port
speaks the line protocol's ``SIM,...`` commands through today's
:class:`~drivers.tracker.line.simulator.server.SimulatorServer`, so the same
``SimulatorControl`` client steers both simulators.
"""

from __future__ import annotations

import contextlib
import socket
import threading
import time

from drivers.tracker.emscon import protocol as pk
from drivers.tracker.emscon.simulator.engine import EmsconOutput, EmsconSimulator
from drivers.tracker.instrument import HangUp, Send
from drivers.tracker.instrument.ticks import TickSchedule, stream_control
from drivers.tracker.line.simulator.server import SimulatorServer


class _Conn:
    """One client connection and its stream (None when not streaming)."""

    def __init__(self, sock: socket.socket) -> None:
        self.sock = sock
        self.stream: TickSchedule | None = None


class EmsconServer:
    """The emScon listener (threads: one accept loop, one thread per connection).

    Parameters
    ----------
    engine : EmsconSimulator
    """

    def __init__(self, engine: EmsconSimulator):
        self.engine = engine
        self._listener: socket.socket | None = None
        self._control = SimulatorServer(engine)
        self._conns: set[socket.socket] = set()
        self._threads: list[threading.Thread] = []
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self.port: int | None = None
        self.control_port: int | None = None

    def open(self, port: int = 0, control_port: int = 0) -> tuple[int, int]:
        """Listen on ``127.0.0.1:port`` (emScon) and ``control_port``; return both ports."""
        lsock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        lsock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        lsock.bind(("127.0.0.1", port))  # loopback only: never reachable from the network
        lsock.listen(4)
        self._listener = lsock
        self.port = lsock.getsockname()[1]
        self.control_port = self._control.open_tcp(control_port)
        return self.port, self.control_port

    def start(self) -> EmsconServer:
        """Serve in daemon threads (after :meth:`open`)."""
        if self._listener is None:
            raise RuntimeError("open() the server before start()")
        self._control.start()
        self._spawn(self._accept_loop, self._listener)
        return self

    def stop(self) -> None:
        """Stop serving; close the listener and every connection."""
        if self._stop.is_set():
            return
        self._stop.set()
        self._control.stop()
        if self._listener is not None:
            with contextlib.suppress(OSError):
                self._listener.shutdown(socket.SHUT_RDWR)
            self._listener.close()
        with self._lock:
            conns = list(self._conns)
        for conn in conns:
            _close(conn)
        for thread in self._threads:
            if thread is not threading.current_thread():
                thread.join(timeout=5)

    def __enter__(self) -> EmsconServer:
        return self

    def __exit__(self, *exc) -> None:
        self.stop()

    def wait(self) -> None:
        """Block until :meth:`stop` (foreground use)."""
        self._stop.wait()

    # ------------------------------------------------------------ internals

    def _spawn(self, target, *args) -> None:
        thread = threading.Thread(target=target, args=args, daemon=True, name="emscon-sim")
        self._threads.append(thread)
        thread.start()

    def _accept_loop(self, listener: socket.socket) -> None:
        while not self._stop.is_set():
            try:
                conn, _ = listener.accept()
            except OSError:
                return  # listener closed by stop()
            conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            with self._lock:
                self._conns.add(conn)
            self._spawn(self._serve, conn)

    def _serve(self, sock: socket.socket) -> None:
        buf = bytearray()
        conn = _Conn(sock)
        try:
            while not self._stop.is_set():
                # While streaming, wake for the next tick; otherwise wait for a command
                # (bounded, so stop() is seen even on an idle connection).
                wait = 0.5 if conn.stream is None else conn.stream.next_due - time.monotonic()
                chunk: bytes | None = None
                if wait > 0:
                    sock.settimeout(wait)
                    try:
                        chunk = sock.recv(65536)
                    except TimeoutError:
                        chunk = None
                    if chunk == b"":
                        return
                if chunk:
                    buf += chunk
                    if not self._commands(conn, buf):
                        return
                if conn.stream is not None and not self._ticks(conn):
                    return
        except OSError:
            return  # client vanished or stop() closed the socket
        finally:
            with self._lock:
                self._conns.discard(sock)
            _close(sock)

    def _commands(self, conn: _Conn, buf: bytearray) -> bool:
        """Answer every complete packet in ``buf``; False to drop the client."""
        while len(buf) >= pk.HEADER.size:
            try:
                size, _ = pk.split_header(buf)
            except pk.PacketSizeError:
                return False  # no way to find the next packet: drop the client
            if len(buf) < size:
                break
            packet = bytes(buf[:size])
            del buf[:size]
            if not self._send(conn, self.engine.handle_packet(packet)):
                return False
        return True

    def _ticks(self, conn: _Conn) -> bool:
        """Send the ticks due now; False to drop the client."""
        stream = conn.stream
        assert stream is not None
        now = time.monotonic()
        stream.catch_up(now)
        while conn.stream is stream and stream.due(now):
            n = stream.advance()
            if not self._send(conn, self.engine.stream_tick(n, stream.stamp_s(n))):
                return False
            if stream.finished:
                conn.stream = None  # lNumberOfPoints sent: the measurement is over
        return True

    def _send(self, conn: _Conn, outputs: list[EmsconOutput]) -> bool:
        """Send (or act on) the engine's outputs in order; False to drop the client."""
        for out in outputs:
            if isinstance(out, HangUp):
                return False
            control, conn.stream = stream_control(out, conn.stream, self.engine, time.monotonic())
            if control:
                continue
            assert isinstance(out, Send)
            if out.delay_s > 0:
                if self._stop.wait(out.delay_s):
                    return False
            conn.sock.sendall(out.data)
        return True


def _close(conn: socket.socket) -> None:
    with contextlib.suppress(OSError):
        conn.shutdown(socket.SHUT_RDWR)
    conn.close()
