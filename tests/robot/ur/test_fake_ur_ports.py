"""The fake UR controller's ports: taken ports are one clean line, and a user's fake is safe.

Run under the machine-wide lock (``flock /tmp/calibrator-fake-ur.lock``): the
fixed ports of 127.0.0.1 are used here as in every fake test.
"""

import socket
import subprocess
import sys
import time

import pytest
from timeout_kit import readline

from drivers.robot.ur.device import UrRtdeRobot
from drivers.robot.ur.simulator.launcher import (
    FakeUrProcess,
    acquire_ports,
    release_ports,
    shutdown_leftover,
)
from drivers.robot.ur.simulator.servers import GREETING

FAKE = [sys.executable, "-m", "drivers.robot.ur.simulator", "--time-scale", "50"]


@pytest.fixture(autouse=True)
def fixed_ports():
    acquire_ports()  # other fake tests on this machine wait
    try:
        yield
    finally:
        release_ports()


def start_by_hand(*args):
    """A fake as a user starts it (no --parent-pid): its process, once it is ready."""
    proc = subprocess.Popen([*FAKE, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        line = readline(proc.stdout, what="'ready'")
    except AssertionError:
        proc.kill()
        raise
    assert b"ready" in line, proc.stderr.read()
    return proc


def dashboard(host, command):
    with socket.create_connection((host, 29999), timeout=2) as sock:
        reader = sock.makefile("rb")
        assert reader.readline().decode().strip() == GREETING
        sock.sendall(command.encode() + b"\n")
        return reader.readline().decode().strip()


def test_taken_ports_are_one_clean_line_and_exit_2():
    with FakeUrProcess(time_scale=50.0):
        done = subprocess.run(FAKE, capture_output=True, text=True, timeout=60)
    assert done.returncode == 2 and done.stdout == ""
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in done.stderr
    assert lines[0].startswith("fake_ur: error: 127.0.0.1:30004 is in use (")
    assert "--host 127.0.0.2" in lines[0]


def test_a_fake_on_another_loopback_address_is_untouched_by_test_runs():
    user = start_by_hand("--host", "127.0.0.2")
    try:
        with FakeUrProcess(time_scale=50.0) as ours:  # the test's fake, on 127.0.0.1
            assert ours.command("fake status") == "fake: status normal"
        robot = UrRtdeRobot("127.0.0.2")  # the real client reaches the user's fake
        robot.connect()
        try:
            assert robot.safety_state().ok
        finally:
            robot.close()
        assert user.poll() is None
        assert dashboard("127.0.0.2", "fake status") == "fake: status normal"
    finally:
        user.terminate()
        user.wait(5)


def test_a_fake_started_by_hand_on_the_fixed_ports_is_reported_never_stopped():
    user = start_by_hand()
    try:
        t0 = time.monotonic()
        with pytest.raises(RuntimeError) as exc:
            shutdown_leftover(timeout_s=0.5)
        assert time.monotonic() - t0 < 5
        assert "in use by a process the tests did not start" in str(exc.value)
        assert user.poll() is None and dashboard("127.0.0.1", "fake status").startswith("fake:")
        with pytest.raises(RuntimeError, match="did not start"):
            FakeUrProcess(time_scale=50.0).start()
        assert user.poll() is None
    finally:
        user.terminate()
        user.wait(5)
    shutdown_leftover()  # and with the user's fake gone the ports are free again


def test_a_bad_host_is_refused_in_one_line():
    done = subprocess.run([*FAKE, "--host", "10.0.0.1"], capture_output=True, text=True, timeout=60)
    assert done.returncode == 2 and "loopback addresses only" in done.stderr
    assert "Traceback" not in done.stderr
