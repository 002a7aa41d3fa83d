"""The same driver over ``rfc2217://``: an RFC 2217 server (pyserial's PortManager) in front of
the simulator's pty, as a serial-device server would sit in front of a real tracker."""

from __future__ import annotations

import socket
import threading

import numpy as np
import pytest
import serial
from serial import rfc2217
from tracker_kit import live_tracker

from drivers.tracker import measure_average

# pyserial's own rfc2217 client still calls Thread.setDaemon/setName.
pytestmark = pytest.mark.filterwarnings(r"ignore:set(Daemon|Name)\(\) is deprecated")

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


@pytest.fixture
def rfc2217_url(served):
    sim, path, _ = served
    bridge = Rfc2217Bridge(path)
    yield sim, f"rfc2217://127.0.0.1:{bridge.port}"
    bridge.close()


def test_driver_over_rfc2217(rfc2217_url):
    sim, url = rfc2217_url
    with live_tracker(url) as tracker:
        status = tracker.connect()
        identity = tracker.identity
        assert identity.serial == "SIM-0001" and status.state == "READY"
        avg = measure_average(tracker, 10)
    assert avg.count == 10
    np.testing.assert_allclose(avg.mean_mm, sim._target, atol=0.03)
