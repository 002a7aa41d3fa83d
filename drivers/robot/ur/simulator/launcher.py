"""Start and stop the fake controller in its own process, and send it test-only commands.

The ``ur-rtde`` client deadlocks against a server in its own interpreter, so
tests run the fake with :class:`FakeUrProcess` (a child process). The ports are
fixed, so only one test fake runs at a time (a machine-wide lock):
:meth:`FakeUrProcess.start` first stops a fake an earlier test run left, and
every fake is started with ``--parent-pid`` so it exits on its own when the
process that started it dies. A fake a user started by hand is never
stopped: the tests report the taken ports instead (start a hand-run fake on
another loopback address, ``--host 127.0.0.2``, to keep both).
"""

from __future__ import annotations

import fcntl
import os
import selectors
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time

from drivers.robot.ur.simulator.servers import DASHBOARD_PORT, HOST, RTDE_PORT, SCRIPT_PORT

_LOCK_PATH = os.path.join(tempfile.gettempdir(), "calibrator-fake-ur-127.0.0.1.lock")
_PID_PATH = os.path.join(tempfile.gettempdir(), "calibrator-fake-ur-127.0.0.1.pid")


class _PortsLock:
    """The process's hold on the machine-wide lock: its file descriptor and nesting depth."""

    fd: int | None = None
    depth: int = 0


_lock_state = _PortsLock()
_lock_mutex = threading.Lock()


def acquire_ports(timeout_s: float = 600.0) -> None:
    """Take the machine-wide lock on the fake's fixed ports (reentrant within a process).

    Two test sessions on one machine would otherwise start fakes on the same
    ports and talk to each other's controller; with the lock the second one
    waits. The lock is an ``flock``, so the kernel drops it when its holder dies.
    """
    with _lock_mutex:
        if _lock_state.depth == 0:
            fd = os.open(_LOCK_PATH, os.O_RDWR | os.O_CREAT, 0o666)
            deadline = time.monotonic() + timeout_s
            while True:
                try:
                    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                    break
                except BlockingIOError:
                    if time.monotonic() > deadline:
                        os.close(fd)
                        raise RuntimeError(f"another process holds {_LOCK_PATH}") from None
                    time.sleep(0.1)
            _lock_state.fd = fd
        _lock_state.depth += 1


def release_ports() -> None:
    """Undo one :func:`acquire_ports`."""
    with _lock_mutex:
        if _lock_state.depth == 0:
            return
        _lock_state.depth -= 1
        if _lock_state.depth == 0 and _lock_state.fd is not None:  # fd is set while depth > 0
            fcntl.flock(_lock_state.fd, fcntl.LOCK_UN)
            os.close(_lock_state.fd)
            _lock_state.fd = None


def dashboard_command(command: str, timeout_s: float = 2.0) -> str:
    """Send one dashboard line to the fake on 127.0.0.1 and return its reply line.

    Parameters
    ----------
    command : str
        E.g. ``"fake protective stop"`` (see ``docs/robot-link.md`` for the list).
    timeout_s : float
        Connect and read deadline, s.
    """
    with socket.create_connection((HOST, DASHBOARD_PORT), timeout=timeout_s) as sock:
        reader = sock.makefile("rb")
        reader.readline()  # greeting
        sock.sendall((command + "\n").encode())
        return reader.readline().decode().strip()


def _port_open(port):
    try:
        with socket.create_connection((HOST, port), timeout=0.2):
            return True
    except OSError:
        return False


def shutdown_leftover(timeout_s: float = 5.0) -> None:
    """Stop a fake an earlier test run left behind; wait until the fixed ports are free.

    Only a fake this launcher started (its pid recorded, its command line a
    fake started with ``--parent-pid``) is ever stopped: a fake a user
    started by hand, or any other program on the ports, is left alone and
    reported.

    Raises
    ------
    RuntimeError
        The ports are still taken, by something this launcher did not start.
    """
    _kill_recorded_fake()
    deadline = time.monotonic() + timeout_s
    while any(_port_open(p) for p in (RTDE_PORT, DASHBOARD_PORT, SCRIPT_PORT)):
        if time.monotonic() > deadline:
            raise RuntimeError(
                f"ports {RTDE_PORT}/{DASHBOARD_PORT}/{SCRIPT_PORT} on {HOST} are in use by a "
                "process the tests did not start (a fake UR controller started by hand?); "
                "it is left running: stop it, or start yours with --host 127.0.0.2"
            )
        time.sleep(0.05)


def _kill_recorded_fake() -> None:
    """SIGKILL the fake whose pid the last launcher recorded, if it is still that fake."""
    try:
        with open(_PID_PATH) as f:
            pid = int(f.read().strip())
        with open(f"/proc/{pid}/cmdline", "rb") as f:
            cmdline = f.read().split(b"\0")
    except (OSError, ValueError):
        return  # no record, or the process is gone
    # The pid was not reused by something else, and it is a launcher's fake, not a user's.
    if b"drivers.robot.ur.simulator" in cmdline and b"--parent-pid" in cmdline:
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass


class FakeUrProcess:
    """The fake controller as a child process (context manager).

    Parameters
    ----------
    time_scale : float
        Passed to ``--time-scale``: simulated motion seconds per wall second.
    startup_timeout_s : float
        How long to wait for the fake to report that it is listening, s.
    model : str
        Named model the fake's arm follows (``--model``).
    unlock_delay_s : float, optional
        ``--unlock-delay``; default the real controller's 5 s.
    """

    def __init__(
        self,
        time_scale: float = 10.0,
        startup_timeout_s: float = 30.0,
        model: str = "ur5e",
        unlock_delay_s: float | None = None,
    ) -> None:
        self.time_scale = time_scale
        self.model = model
        self.unlock_delay_s = unlock_delay_s
        self.startup_timeout_s = startup_timeout_s
        self.process: subprocess.Popen[bytes] | None = None
        self._holds_lock = False

    def start(self) -> FakeUrProcess:
        acquire_ports()
        self._holds_lock = True
        try:
            self._start()
        except BaseException:
            self.stop()
            raise
        return self

    def _start(self):
        shutdown_leftover()
        cmd = [
            sys.executable,
            "-m",
            "drivers.robot.ur.simulator",
            "--time-scale",
            str(self.time_scale),
            "--parent-pid",
            str(os.getpid()),
            "--model",
            self.model,
        ]
        if self.unlock_delay_s is not None:
            cmd += ["--unlock-delay", str(self.unlock_delay_s)]
        # stderr to a file: a pipe nobody reads would block the fake once full
        self._stderr = tempfile.TemporaryFile()
        # own session: signals meant for the test runner's group do not reach it
        self.process = subprocess.Popen(
            cmd, stdout=subprocess.PIPE, stderr=self._stderr, start_new_session=True
        )
        with open(_PID_PATH, "w") as f:
            f.write(str(self.process.pid))
        selector = selectors.DefaultSelector()
        selector.register(self.process.stdout, selectors.EVENT_READ)
        ready = selector.select(self.startup_timeout_s)
        selector.close()
        line = self.process.stdout.readline() if ready else b""
        if b"ready" not in line:
            self.process.kill()
            self.process.wait(3)
            self._stderr.seek(0)
            err = self._stderr.read().decode(errors="replace")
            raise RuntimeError(f"fake UR controller did not start: {err.strip()[-500:]}")

    def command(self, text: str) -> str:
        """A dashboard command to this fake, e.g. ``"fake estop"``; returns the reply line."""
        return dashboard_command(text)

    @property
    def running(self) -> bool:
        return self.process is not None and self.process.poll() is None

    def stop(self) -> None:
        """Terminate the fake (kill it if it does not exit within 3 s) and free the ports."""
        try:
            self._terminate()
        finally:
            if self._holds_lock:
                self._holds_lock = False
                release_ports()

    def _terminate(self):
        if self.process is None:
            return
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(3)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait(3)
        self.process.stdout.close()
        self._stderr.close()

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc):
        self.stop()
