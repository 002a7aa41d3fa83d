"""Test helpers: a scripted transport in the expected-protocol style, frame builders.

:class:`ScriptedTransport` stands in for the serial port (not for the
driver): every write must equal the next scripted host frame, its scripted
reply then becomes readable, and :meth:`ScriptedTransport.verify` fails on
unused pairs or on reply bytes the driver never read.
"""

from __future__ import annotations

import contextlib
import socket
import threading
import time
from pathlib import Path

import serial
from serial import rfc2217

from drivers.tracker import LaserTracker
from drivers.tracker.line.protocol import encode_frame
from drivers.tracker.line.simulator.engine import Send

REPO = Path(__file__).resolve().parents[2]


def host(seq: int, *fields: str) -> bytes:
    """A host frame ``<seq>,<fields...>*CRC\\r\\n``."""
    return encode_frame(",".join([str(seq), *fields]))


def trk(body: str) -> bytes:
    """A tracker frame for ``body`` (e.g. ``"OK,1,READY"``)."""
    return encode_frame(body)


class ScriptedTransport:
    """Serial-like fake replaying ``(expected_write, reply)`` pairs.

    Parameters
    ----------
    pairs : list of (bytes, bytes or None)
        The frame the driver must write next, and the bytes that become
        readable after it (None: nothing, as for a dropped reply).
    """

    def __init__(self, pairs):
        self.pairs = list(pairs)
        self.used = 0
        self.rx = bytearray()
        self.timeout: float | None = 1.0
        self.is_open = True

    # -- serial-like surface
    def write(self, data: bytes) -> int:
        assert self.used < len(self.pairs), f"unexpected write {data!r}: all pairs used"
        expected, reply = self.pairs[self.used]
        assert data == expected, f"pair {self.used}: expected {expected!r}, got {data!r}"
        self.used += 1
        if reply:
            self.rx += reply
        return len(data)

    @property
    def in_waiting(self) -> int:
        return len(self.rx)

    def read(self, size: int = 1) -> bytes:
        chunk = bytes(self.rx[:size])
        del self.rx[:size]
        return chunk

    def read_until(self, expected: bytes = b"\n", size: int | None = None) -> bytes:
        end = self.rx.find(expected)
        n = len(self.rx) if end < 0 else end + len(expected)
        if size is not None:
            n = min(n, size)
        return self.read(n)

    def reset_input_buffer(self) -> None:
        assert not self.rx, f"driver discarded unread reply bytes {bytes(self.rx)!r}"

    def close(self) -> None:
        self.is_open = False

    # -- checks
    def verify(self) -> None:
        unused = self.pairs[self.used :]
        assert not unused, f"{len(unused)} scripted pairs unused, next: {unused[0][0]!r}"
        assert not self.rx, f"reply bytes left unread: {bytes(self.rx)!r}"


@contextlib.contextmanager
def expected_exchange(pairs, **tracker_kwargs):
    """Yield a :class:`LaserTracker` on a :class:`ScriptedTransport`; verify it on exit."""
    transport = ScriptedTransport(pairs)
    tracker = LaserTracker(transport, reconnect_attempts=0, **tracker_kwargs)
    yield tracker
    transport.verify()


LIVE_TIMEOUT_S = 10.0
"""Deadline for commands that should succeed against a live simulator. Generous because
it costs nothing when replies come, and the test machine may be heavily loaded."""


def live_tracker(url, **kwargs) -> LaserTracker:
    """A :class:`LaserTracker` for a live simulator, with generous deadlines unless overridden."""
    opts = dict(
        timeout_s=LIVE_TIMEOUT_S,
        measure_timeout_s=LIVE_TIMEOUT_S,
        init_timeout_s=LIVE_TIMEOUT_S,
        reconnect_delay_s=0.05,
    )
    opts.update(kwargs)
    return LaserTracker(url, **opts)


CONNECT_PAIRS = [
    (host(1, "ID?"), trk("OK,1,ACME,AT-X,123,2.1")),
    (host(2, "UNITS", "MM", "RAD"), trk("OK,2,MM,RAD")),
    (host(3, "STAT?"), trk("OK,3,READY,1,1,P3,STANDARD")),
]
"""What :meth:`LaserTracker.connect` exchanges with no environment or mode given."""


class DevicePort:
    """Serial-like fake of a port with a device behind it that answers on its own clock.

    Unlike :class:`ScriptedTransport` it has no script: ``respond(line)`` returns
    ``[(delay_s, bytes), ...]`` for each complete line written, and each reply
    becomes readable ``delay_s`` after the write (so a reply can arrive late,
    after a reconnect). Reads honour ``timeout`` like pyserial.

    Parameters
    ----------
    respond : callable
        ``respond(line: bytes) -> list[tuple[float, bytes]]``.
    """

    def __init__(self, respond):
        self.respond = respond
        self.timeout: float | None = 1.0
        self.write_timeout: float | None = None
        self.is_open = True
        self.fail_reads = 0  # the next N reads raise SerialException (port vanished)
        self.junk = b""  # served forever, instead of any reply, while endless_junk
        self.endless_junk = False
        self.rx = bytearray()
        self._inbuf = bytearray()
        self._pending: list[tuple[float, bytes]] = []

    def _pump(self) -> None:
        now = time.monotonic()
        due = [p for p in self._pending if p[0] <= now]
        self._pending = [p for p in self._pending if p[0] > now]
        if self.endless_junk:  # a device stuck sending one line: no reply gets out
            if len(self.rx) < 65536:
                self.rx += self.junk
            return
        for _, data in sorted(due, key=lambda p: p[0]):
            self.rx += data

    def _check(self) -> None:
        if not self.is_open:
            raise serial.PortNotOpenError()
        if self.fail_reads:
            self.fail_reads -= 1
            raise serial.SerialException("device reports readiness to read but returned no data")

    def write(self, data: bytes) -> int:
        if not self.is_open:
            raise serial.PortNotOpenError()
        self._inbuf += data
        now = time.monotonic()
        while (end := self._inbuf.find(b"\r\n")) >= 0:
            line = bytes(self._inbuf[: end + 2])
            del self._inbuf[: end + 2]
            for delay, reply in self.respond(line):
                self._pending.append((now + delay, reply))
        return len(data)

    @property
    def in_waiting(self) -> int:
        self._check()
        self._pump()
        return len(self.rx)

    def read(self, size: int = 1) -> bytes:
        self._check()
        deadline = time.monotonic() + (self.timeout if self.timeout is not None else 3600.0)
        while True:
            self._pump()
            if self.rx or time.monotonic() >= deadline:
                chunk = bytes(self.rx[:size])
                del self.rx[:size]
                return chunk
            time.sleep(0.001)

    def read_until(self, expected: bytes = b"\n", size: int | None = None) -> bytes:
        self._check()
        deadline = time.monotonic() + (self.timeout if self.timeout is not None else 3600.0)
        while True:
            self._pump()
            end = self.rx.find(expected)
            if end >= 0 or (size is not None and len(self.rx) >= size):
                n = len(self.rx) if end < 0 else end + len(expected)
                n = n if size is None else min(n, size)
                chunk = bytes(self.rx[:n])
                del self.rx[:n]
                return chunk
            if time.monotonic() >= deadline:
                chunk = bytes(self.rx)
                self.rx.clear()
                return chunk
            time.sleep(0.001)

    def reset_input_buffer(self) -> None:
        self._check()
        self._pump()
        self.rx.clear()

    def close(self) -> None:
        self.is_open = False

    def open(self) -> None:
        self.is_open = True


def engine_responder(engine, meas_delay_s: float = 0.0):
    """``respond`` for :class:`DevicePort` from a simulator engine; MEAS replies come late."""

    def respond(line: bytes):
        late = b",MEAS*" in line
        return [
            (out.delay_s + (meas_delay_s if late else 0.0), out.data)
            for out in engine.handle_line(line)
            if isinstance(out, Send)
        ]

    return respond


def stat_half_second_left(port) -> None:
    """One ``STAT?`` through a :class:`~drivers.tracker.line.link.Link` on ``port``, 0.5 s left
    at every read and write (a stopped clock); the reply must be read and the script used up.
    """
    from drivers.tracker.line.link import Link

    link = Link(port, clock=lambda: 1000.0)
    assert link.transact("STAT?", timeout_s=0.5).seq == 1
    port.verify()


#: ``(timeout the port has, what the link sets it to)`` with 0.5 s left for an
#: I/O: the link bounds a read or a write by the time left, and leaves a bound
#: alone from half that time up to it.
TIMEOUT_BOUNDS = [
    (None, [0.5]),  # no bound yet
    (0.6, [0.5]),  # longer than the time left
    (0.5, []),  # exactly the time left
    (0.4, []),
    (0.25, []),  # exactly half the time left
    (0.24, [0.5]),  # far too short for the time left
]


# ------------------------------------------------- an RFC 2217 server in front of a pty

MODEM_LINES = ("dtr", "rts", "break_condition")


class _PtyWithoutModemLines:
    """A pty has no modem lines; report them idle and ignore settings, pass everything else."""

    cts = dsr = ri = cd = False

    def __init__(self, port: serial.Serial):
        object.__setattr__(self, "_port", port)

    def __getattr__(self, name):
        return getattr(self._port, name)

    def __setattr__(self, name, value):
        if name not in MODEM_LINES:
            setattr(self._port, name, value)


class _SocketWriter:
    """PortManager writes its Telnet replies through ``write``."""

    def __init__(self, sock: socket.socket):
        self._sock = sock

    def write(self, data: bytes) -> None:
        self._sock.sendall(data)


class Rfc2217Bridge:
    """Serve one pty over RFC 2217 on 127.0.0.1, one client, two pump threads."""

    def __init__(self, pty_path: str):
        self._serial = serial.Serial(pty_path, timeout=0.05)
        self._listener = socket.create_server(("127.0.0.1", 0))
        self.port = self._listener.getsockname()[1]
        self._stop = threading.Event()
        self._threads = [threading.Thread(target=self._serve, daemon=True)]
        self._threads[0].start()

    def _serve(self) -> None:
        conn, _ = self._listener.accept()
        self._conn = conn
        conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        manager = rfc2217.PortManager(_PtyWithoutModemLines(self._serial), _SocketWriter(conn))
        pump = threading.Thread(target=self._device_to_net, args=(manager, conn), daemon=True)
        pump.start()
        self._threads.append(pump)
        try:
            while not self._stop.is_set():
                data = conn.recv(4096)
                if not data:
                    break
                self._serial.write(b"".join(manager.filter(data)))
        except OSError:
            pass  # closed during teardown

    def _device_to_net(self, manager, conn) -> None:
        try:
            while not self._stop.is_set():
                data = self._serial.read(self._serial.in_waiting or 1)
                if data:
                    conn.sendall(b"".join(manager.escape(data)))
        except (OSError, serial.SerialException):
            pass  # closed during teardown

    def close(self) -> None:
        self._stop.set()
        self._listener.close()
        if hasattr(self, "_conn"):
            self._conn.close()
        for thread in self._threads:
            thread.join(timeout=2)
        self._serial.close()
