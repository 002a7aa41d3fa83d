"""Socket servers of the fake controller: RTDE (30004), dashboard (29999), script (30003).

All three listen on 127.0.0.1 only, with ``SO_REUSEADDR`` so a fake can start
right after another one died. Each client connection gets its own thread; the
shared :class:`~drivers.robot.ur.simulator.controller.FakeController` holds the state.
"""

from __future__ import annotations

import re
import socket
import threading
import time

from drivers.robot.ur.simulator.controller import ROBOT_MODES, FakeController, safety_mode
from drivers.robot.ur.simulator.rtde_session import RtdeSession

HOST = "127.0.0.1"
RTDE_PORT = 30004
DASHBOARD_PORT = 29999
SCRIPT_PORT = 30003

POLYSCOPE_VERSION = "URSoftware 5.11.1.108318 (Mar 22 2021)"
SERIAL_NUMBER = "20185500020"
GREETING = "Connected: Universal Robots Dashboard Server"

_REG_OFFSET = re.compile(r"global reg_offset_int\s*=\s*(?:#[^\n]*\n\s*)?(\d+)")


class PortsInUse(OSError):
    """A port the fake needs is taken (another fake, or any other program)."""


def listen(port: int, host: str = HOST) -> socket.socket:
    """A listening socket on ``host:port`` that can rebind over TIME_WAIT leftovers.

    Raises
    ------
    PortsInUse
        Something already listens there.
    """
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind((host, port))
    except OSError as exc:
        sock.close()
        raise PortsInUse(
            f"{host}:{port} is in use ({exc.strerror}): another fake UR controller or another "
            "program listens there; stop it, or start this one on another loopback address "
            "(--host 127.0.0.2, then ur://127.0.0.2) or other ports"
        ) from None
    sock.listen(8)
    return sock


class FakeUr:
    """The three servers plus the controller clock, all in this process.

    Parameters
    ----------
    controller : FakeController
        State shared by all servers.
    host : str
        Loopback address to listen on (any 127.x.y.z: each has its own ports).
    ports : tuple of int
        RTDE, dashboard and script ports (``ur-rtde`` expects the defaults).
    """

    def __init__(
        self,
        controller: FakeController,
        host: str = HOST,
        ports: tuple[int, int, int] = (RTDE_PORT, DASHBOARD_PORT, SCRIPT_PORT),
    ) -> None:
        self.controller = controller
        self.host = host
        self.ports = ports
        self.stopped = threading.Event()
        self._conns: set[socket.socket] = set()
        self._conns_lock = threading.Lock()
        self._listeners: list[socket.socket] = []

    # ------------------------------------------------------------ lifecycle
    def start(self) -> None:
        """Bind all ports, then start the clock and accept loops (returns at once)."""
        handlers = [self._serve_rtde, self._serve_dashboard, self._serve_script]
        try:  # all ports or none: a fake with half its servers would confuse a client
            listeners = []
            for port in self.ports:
                listeners.append(listen(port, self.host))
        except PortsInUse:
            for sock in listeners:
                _close(sock)
            raise
        self._listeners = listeners
        for sock, handler in zip(listeners, handlers, strict=True):
            threading.Thread(target=self._accept_loop, args=(sock, handler), daemon=True).start()
        threading.Thread(target=self._clock, daemon=True).start()

    def drop(self) -> None:
        """Hang up: close every connection and stop listening (the controller is gone)."""
        self.stopped.set()
        for sock in self._listeners:
            _close(sock)
        with self._conns_lock:
            conns = list(self._conns)
        for conn in conns:
            _close(conn)

    def _clock(self):
        period = self.controller.period_s
        last = time.monotonic()
        next_at = last + period
        while not self.stopped.is_set():
            delay = next_at - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            now = time.monotonic()
            self.controller.tick(now - last)
            last = now
            # if we fell behind, do not burst to catch up
            next_at = max(next_at + period, now)

    def _accept_loop(self, sock, handler):
        while not self.stopped.is_set():
            try:
                conn, _ = sock.accept()
            except OSError:
                return
            conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            with self._conns_lock:
                self._conns.add(conn)
            threading.Thread(target=self._run_handler, args=(handler, conn), daemon=True).start()

    def _run_handler(self, handler, conn):
        try:
            handler(conn)
        except OSError:
            pass  # the client went away (or we dropped it): nothing to report
        finally:
            with self._conns_lock:
                self._conns.discard(conn)
            _close(conn)

    # ------------------------------------------------------------------ RTDE
    def _serve_rtde(self, conn):
        RtdeSession(conn, self.controller, self.stopped).run()

    # ------------------------------------------------------------- dashboard
    def _serve_dashboard(self, conn):
        conn.sendall((GREETING + "\n").encode())
        buffer = b""
        while not self.stopped.is_set():
            chunk = conn.recv(1024)
            if not chunk:
                return
            buffer += chunk
            while b"\n" in buffer:
                line, buffer = buffer.split(b"\n", 1)
                reply = self._dashboard_reply(line.decode("ascii", "replace").strip())
                if reply is None:
                    return
                conn.sendall((reply + "\n").encode())
                if reply == "Disconnected":
                    return

    def _dashboard_reply(self, command):
        c = self.controller
        lower = command.lower()
        if lower == "polyscopeversion":
            return POLYSCOPE_VERSION
        if lower == "get serial number":
            return SERIAL_NUMBER
        if lower == "stop":
            c.stop_program()
            return "Stopped"
        if lower == "unlock protective stop":
            return c.unlock_protective_stop()
        if lower == "is in remote control":
            return "true"
        if lower == "robotmode":
            return f"Robotmode: {ROBOT_MODES[c.robot_mode]}"
        if lower == "power on":
            return c.power_on()
        if lower == "brake release":
            return c.brake_release()
        if lower == "power off":
            return c.power_off()
        if lower in ("safetystatus", "safetymode"):
            mode = {1: "NORMAL", 3: "PROTECTIVE_STOP", 7: "ROBOT_EMERGENCY_STOP"}
            return f"Safety{lower[6:]}: {mode[safety_mode(c.safety_bits)]}"
        if lower == "programstate":
            playing = c.runtime_state == 2
            return "PLAYING rtde_control" if playing else "STOPPED <unnamed>"
        if lower == "quit":
            return "Disconnected"
        if lower.startswith("fake "):
            return self._test_command(lower[5:].strip())
        return f"could not understand: '{command}'"

    def _test_command(self, command):
        """Test-only dashboard commands (``fake ...``); not part of any real controller."""
        c = self.controller
        if command == "protective stop":
            c.protective_stop()
            return "fake: protective stop"
        if command == "estop":
            c.emergency_stop()
            return "fake: emergency stop"
        if command == "release estop":
            c.release_emergency_stop()
            return "fake: emergency stop released"
        if command == "stall":
            # a frozen controller: open connections stay open but go silent, and
            # nothing new is accepted (else the client would reconnect forever)
            c.stalled = True
            for sock in self._listeners:
                _close(sock)
            return "fake: stalled"
        if command == "freeze timestamp":
            # a hung controller that keeps its sockets and repeats its last packet
            c.frozen_timestamp = c.timestamp()
            return "fake: timestamp frozen"
        if command.startswith("safety lag "):
            c.set_safety_lag(command.split()[-1])
            return f"fake: safety lag {c.safety_lag_s:g}"
        if command.startswith("program lag "):
            c.set_program_lag(command.split()[-1])
            return f"fake: program lag {c.program_lag_s:g}"
        if command.startswith("estop at movej "):
            c.estop_at_movej = int(command.split()[-1])
            return f"fake: estop at movej {c.estop_at_movej}"
        if command == "joints":
            with c.lock:
                return "fake: joints " + " ".join(f"{v:.9f}" for v in c.q)
        if command.startswith("unlock delay "):
            c.unlock_delay_s = float(command.split()[-1])
            return f"fake: unlock delay {c.unlock_delay_s:g}"
        if command == "status":
            # "normal" only when nothing a test injected is still in effect
            with c.lock:
                flags = [
                    name
                    for name, on in (
                        ("protective_stop", c.safety_bits & 4),
                        ("emergency_stop", c.safety_bits & 128),
                        ("stalled", c.stalled),
                        ("timestamp_frozen", c.frozen_timestamp is not None),
                        ("safety_lag", c.safety_lag_s),
                        ("program_lag", c.program_lag_s),
                        ("estop_pending", c.estop_at_movej),
                        ("moving", c.moving),
                        ("not_running", c.robot_mode != 7),
                    )
                    if on
                ]
            return "fake: status " + (" ".join(flags) or "normal")
        if command == "moving":
            return f"fake: moving {str(c.moving).lower()}"
        if command in ("drop", "shutdown"):
            # reply first, then hang up everything from another thread
            threading.Timer(0.05, self.drop).start()
            return f"fake: {command}"
        return f"fake: unknown test command '{command}'"

    # ---------------------------------------------------------------- script
    def _serve_script(self, conn):
        buffer = ""
        while not self.stopped.is_set():
            chunk = conn.recv(65536)
            if not chunk:
                return
            buffer += chunk.decode("utf-8", "replace")
            # a control program is complete once its closing "end" line arrived
            if "def rtde_control():" in buffer and buffer.rstrip().endswith("end"):
                match = _REG_OFFSET.search(buffer)
                self.controller.start_program(int(match.group(1)) if match else 0)
                buffer = ""


def _close(sock):
    try:
        sock.shutdown(socket.SHUT_RDWR)
    except OSError:
        pass
    try:
        sock.close()
    except OSError:
        pass
