"""Serve a simulated tracker over a pty and/or loopback TCP: one select loop, no threads per client.

The server owns the master side of a pty (the client opens the slave path,
e.g. ``/dev/pts/7``) and/or a listening socket bound to 127.0.0.1. All
connections share one tracker, so a simulated robot can send
``SIM,TARGET`` over TCP while the driver measures over the pty.
"""

from __future__ import annotations

import errno
import os
import select
import socket
import threading
import time
import tty
from collections import deque
from collections.abc import Sequence
from typing import Protocol

from drivers.tracker.instrument import HangUp, Send
from drivers.tracker.instrument.ticks import TickSchedule, stream_control
from drivers.tracker.line.protocol import MAX_FRAME, TERMINATOR
from drivers.tracker.line.simulator.engine import LineOutput, internal_error_reply


class LineEngine(Protocol):
    """What the server drives: one complete command line in, the outputs to send back."""

    def handle_line(self, line: bytes) -> Sequence[LineOutput]: ...


class _Conn:
    """One client connection: a pty master fd or an accepted socket."""

    def __init__(self, fd: int, sock: socket.socket | None = None, slave_fd: int | None = None):
        self.fd = fd
        self.sock = sock
        self.slave_fd = slave_fd  # held open so the master never reads EIO between clients
        self.inbuf = bytearray()
        self.out: deque[list] = deque()  # [due_time, bytes]; FIFO keeps the line order
        self.last_due = 0.0
        self.is_pty = sock is None
        self.stream: TickSchedule | None = None

    def read(self) -> bytes:
        return self.sock.recv(65536) if self.sock else os.read(self.fd, 65536)

    def write(self, data: bytes) -> int:
        return self.sock.send(data) if self.sock else os.write(self.fd, data)

    def close(self) -> None:
        if self.sock:
            self.sock.close()
        else:
            os.close(self.fd)
            if self.slave_fd is not None:
                os.close(self.slave_fd)


class SimulatorServer:
    """Select-loop server around a :class:`TrackerSimulator` or :class:`ReplaySimulator`.

    Parameters
    ----------
    engine : object
        Anything with ``handle_line(bytes) -> list[Send | HangUp]``.

    Notes
    -----
    A ``hangup`` on the pty closes the master: the slave path disappears for
    good, as when a USB adapter is unplugged. A ``hangup`` on TCP closes that
    client; the port keeps listening, so a reconnect succeeds.
    """

    def __init__(self, engine: LineEngine) -> None:
        self.engine = engine
        self._conns: list[_Conn] = []
        self._listeners: list[socket.socket] = []
        self._wake_r, self._wake_w = os.pipe()
        self._stop = False
        self._thread: threading.Thread | None = None
        self.pty_path: str | None = None
        self.tcp_port: int | None = None

    # ------------------------------------------------------------ endpoints

    def open_pty(self) -> str:
        """Create a pty; return the slave path a client opens (``/dev/pts/N``)."""
        master, slave = os.openpty()
        tty.setraw(slave)  # no echo, no line discipline: bytes pass unchanged
        os.set_blocking(master, False)
        self._conns.append(_Conn(master, slave_fd=slave))
        self.pty_path = os.ttyname(slave)
        return self.pty_path

    def open_tcp(self, port: int = 0) -> int:
        """Listen on ``127.0.0.1:port`` (0 picks a free port); return the port."""
        lsock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        lsock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        lsock.bind(("127.0.0.1", port))  # loopback only: never reachable from the network
        lsock.listen(4)
        lsock.setblocking(False)
        self._listeners.append(lsock)
        self.tcp_port = lsock.getsockname()[1]
        return self.tcp_port

    # ------------------------------------------------------------ running

    def start(self) -> SimulatorServer:
        """Serve in a daemon thread (for in-process use by tests and the embedded default)."""
        self._thread = threading.Thread(target=self.serve_forever, name="tracker-sim", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        """Stop serving and close every endpoint."""
        if self._stop:
            return
        self._stop = True
        os.write(self._wake_w, b"x")
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=5)
        self._close_all()
        for fd in (self._wake_r, self._wake_w):
            try:
                os.close(fd)
            except OSError:
                pass  # already closed by an earlier stop()

    def __enter__(self) -> SimulatorServer:
        return self

    def __exit__(self, *exc) -> None:
        self.stop()

    def serve_forever(self) -> None:
        """Run until :meth:`stop`, or until the last endpoint is gone (pty hang-up)."""
        try:
            while not self._stop and (self._conns or self._listeners):
                self._tick(time.monotonic())
                self._flush(time.monotonic())
                rlist: list[int | socket.socket] = [
                    self._wake_r,
                    *self._listeners,
                    *(c.fd for c in self._conns),
                ]
                wlist = [c.fd for c in self._conns if c.out and c.out[0][0] <= time.monotonic()]
                ready_r, ready_w, _ = select.select(rlist, wlist, [], self._timeout())
                if self._wake_r in ready_r:
                    break
                for lsock in self._listeners:
                    if lsock in ready_r:
                        self._accept(lsock)
                for conn in list(self._conns):
                    if conn.fd in ready_r:
                        self._receive(conn)
        finally:
            if self._thread is None:  # foreground: nobody else will close
                self._close_all()

    def _timeout(self) -> float | None:
        dues = [c.out[0][0] for c in self._conns if c.out]
        dues += [c.stream.next_due for c in self._conns if c.stream is not None]
        return max(0.0, min(dues) - time.monotonic()) if dues else None

    def _tick(self, now: float) -> None:
        """Queue the stream ticks that are due, each measured at its own due time."""
        for conn in list(self._conns):
            stream = conn.stream
            if stream is None or stream.next_due > now:
                continue
            stream.catch_up(now)
            while conn.stream is stream and stream.due(now):
                n = stream.advance()
                engine = self.engine
                outputs = engine.stream_tick(stream.id, n, stream.stamp_s(n))  # type: ignore[attr-defined]
                if not self._queue(conn, outputs):
                    break
                if stream.finished and conn.stream is stream:
                    end = self.engine.stream_end(stream.id, stream.n)  # type: ignore[attr-defined]
                    self._queue(conn, [Send(end)])
                    conn.stream = None

    def _accept(self, lsock: socket.socket) -> None:
        try:
            sock, _ = lsock.accept()
        except BlockingIOError:
            return
        sock.setblocking(False)
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)  # replies are tiny
        self._conns.append(_Conn(sock.fileno(), sock=sock))

    def _receive(self, conn: _Conn) -> None:
        try:
            data = conn.read()
        except BlockingIOError:
            return
        except OSError:
            data = b""
        if not data:
            self._drop(conn)
            return
        conn.inbuf += data
        while True:
            end = conn.inbuf.find(TERMINATOR)
            if end < 0:
                if len(conn.inbuf) > MAX_FRAME:  # never let a missing terminator grow us
                    line, conn.inbuf = bytes(conn.inbuf[:MAX_FRAME]), bytearray()
                    self._answer(conn, line)
                return
            line = bytes(conn.inbuf[: end + 2])
            del conn.inbuf[: end + 2]
            if not self._answer(conn, line):
                return

    def _answer(self, conn: _Conn, line: bytes) -> bool:
        """Queue the engine's outputs; False if the connection was hung up."""
        try:
            outputs = self.engine.handle_line(line)
        except Exception as exc:  # noqa: BLE001 - one bad line must not stop a shared device
            # The engine validates what it parses; this is the last line of defence,
            # so a bug shows as an ER reply to that client, not a dead simulator.
            outputs = [internal_error_reply(line, exc)]
        if not self._queue(conn, outputs):
            return False
        self._flush(time.monotonic())
        return True

    def _queue(self, conn: _Conn, outputs: Sequence[LineOutput]) -> bool:
        """Queue outputs on ``conn`` in order; False if it was hung up."""
        for out in outputs:
            if isinstance(out, HangUp):
                self._drop(conn)
                return False
            engine = self.engine  # a live simulator (a replay starts no streams)
            now = time.monotonic()
            control, conn.stream = stream_control(out, conn.stream, engine, now)  # type: ignore[arg-type]
            if control:
                continue
            assert isinstance(out, Send)
            due = max(time.monotonic(), conn.last_due) + out.delay_s
            conn.last_due = due
            conn.out.append([due, out.data])
        return True

    def _flush(self, now: float) -> None:
        for conn in list(self._conns):
            while conn.out and conn.out[0][0] <= now:
                data = conn.out[0][1]
                try:
                    n = conn.write(data)
                except BlockingIOError:
                    break
                except OSError as exc:
                    if exc.errno in (errno.EAGAIN, errno.EINTR):
                        break
                    self._drop(conn)
                    break
                if n < len(data):
                    conn.out[0][1] = data[n:]
                    break
                conn.out.popleft()

    def _drop(self, conn: _Conn) -> None:
        if conn in self._conns:
            self._conns.remove(conn)
            conn.close()
            if conn.is_pty:
                self.pty_path = None

    def _close_all(self) -> None:
        for conn in list(self._conns):
            self._drop(conn)
        for lsock in self._listeners:
            lsock.close()
        self._listeners.clear()
