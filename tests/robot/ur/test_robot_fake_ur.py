"""The fake UR controller itself: its RTDE wire answers, dashboard and script loop.

Wire tests use a few lines of raw sockets (no ur-rtde) so that a fault in the
fake is told apart from a fault in the adapter; the controller's register loop
is tested in-process, without sockets.
"""

import socket
import struct
import subprocess
import sys

import numpy as np
import pytest

from drivers.robot.ur.simulator import wire
from drivers.robot.ur.simulator.controller import (
    CMD_IS_STEADY,
    CMD_MOVEJ,
    CMD_STOP_SCRIPT,
    CMD_STOPJ,
    DONE,
    READY,
    RUNTIME_PLAYING,
    RUNTIME_STOPPED,
    FakeController,
    _JointMove,
)


# --------------------------------------------------------- raw RTDE client
class RawRtde:
    def __init__(self):
        self.sock = socket.create_connection(("127.0.0.1", 30004), timeout=3)

    def send(self, package_type, payload=b""):
        self.sock.sendall(wire.pack(package_type, payload))

    def receive(self):
        head = self._exact(3)
        size, package_type = wire.HEADER.unpack(head)
        return package_type, self._exact(size - 3)

    def request(self, package_type, payload=b""):
        self.send(package_type, payload)
        reply_type, body = self.receive()
        assert reply_type == package_type
        return body

    def _exact(self, n):
        data = b""
        while len(data) < n:
            chunk = self.sock.recv(n - len(data))
            assert chunk, "fake closed the connection"
            data += chunk
        return data

    def close(self):
        self.sock.close()


@pytest.fixture
def raw(fake_ur):
    client = RawRtde()
    yield client
    client.close()


def test_protocol_and_controller_version(raw):
    assert raw.request(ord("V"), struct.pack(">H", 2)) == b"\x01"
    major, minor, _, _ = struct.unpack(">IIII", raw.request(ord("v")))
    assert (major, minor) >= (5, 6)  # 5.6+: the client asks the dashboard for versions


def test_outputs_typed_unknown_names_zero_and_stream_rising(raw):
    names = [
        "timestamp",
        "actual_q",
        "joint_mode",
        "runtime_state",
        "actual_digital_input_bits",
        "output_int_register_0",
        "no_such_variable",
    ]
    body = raw.request(ord("O"), struct.pack(">d", 125.0) + (",".join(names) + ",").encode())
    types = body[1:].decode().split(",")
    assert types == ["DOUBLE", "VECTOR6D", "VECTOR6INT32", "UINT32", "UINT64", "INT32", "DOUBLE"]
    assert "NOT_FOUND" not in types
    assert raw.request(ord("S")) == b"\x01"
    recipe = wire.recipe_struct(types)
    stamps = []
    while len(stamps) < 5:
        package_type, payload = raw.receive()
        assert package_type == ord("U")
        values = recipe.unpack(payload[1:])
        stamps.append(values[0])
        assert values[-1] == 0.0  # the unknown variable is served as zero
        assert values[7:13] == (253,) * 6  # joints in running mode
    assert all(b > a for a, b in zip(stamps, stamps[1:], strict=False))
    # 125 Hz requested: five packages span about four periods, not 500 Hz worth
    assert stamps[-1] - stamps[0] > 3 * (1 / 125) * 0.5


def test_input_recipes_numbered_per_connection(raw):
    first = raw.request(ord("I"), b"input_int_register_0,input_double_register_0,")
    second = raw.request(ord("I"), b"input_int_register_1,")
    assert first == b"\x01INT32,DOUBLE"
    assert second == b"\x02INT32"
    other = RawRtde()
    try:
        assert other.request(ord("I"), b"input_int_register_0,")[0] == 1
    finally:
        other.close()


def test_dashboard_commands(fake_ur):
    with socket.create_connection(("127.0.0.1", 29999), timeout=3) as sock:
        reader = sock.makefile("rb")
        assert b"Dashboard Server" in reader.readline()

        def ask(line):
            sock.sendall(line.encode() + b"\n")
            return reader.readline().decode().strip()

        version = ask("PolyscopeVersion")
        assert any(part.count(".") == 3 for part in version.split())  # d.d.d.d
        assert ask("get serial number").isdigit()
        assert ask("stop") == "Stopped"
        assert ask("fake status") == "fake: status normal"
        assert ask("fake protective stop") == "fake: protective stop"
        assert ask("fake status") == "fake: status protective_stop"
        assert ask("unlock protective stop") == "Protective stop releasing"
        assert ask("fake status") == "fake: status normal"
        assert ask("what") == "could not understand: 'what'"


def test_runs_as_a_module_with_help():
    out = subprocess.run(
        [sys.executable, "-m", "drivers.robot.ur.simulator", "--help"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert out.returncode == 0
    assert "--time-scale" in out.stdout


# ----------------------------------------------- register loop, in process
def run_command(controller, cmd, ints=(), doubles=(), ticks=1, dt=0.002):
    """Write a command as the client does, tick, and return out_int_register_0."""
    for i, value in enumerate(doubles):
        controller.in_double[i] = value
    for i, value in ints:
        controller.in_int[i] = value
    controller.in_int[0] = cmd
    for _ in range(ticks):
        controller.tick(dt)
    return int(controller.out_int[0])


def test_register_handshake_movej_and_is_steady():
    c = FakeController(time_scale=10.0)
    assert c.runtime_state == RUNTIME_STOPPED
    c.start_program()
    assert c.runtime_state == RUNTIME_PLAYING
    assert run_command(c, 0) == READY
    target = c.q + np.array([0.2, 0.0, -0.1, 0.0, 0.0, 0.1])
    # a synchronous movej holds the loop: no DONE until the arm is there
    assert run_command(c, CMD_MOVEJ, ints=[(1, 0)], doubles=[*target, 1.0, 2.0]) == READY
    assert c.moving
    for _ in range(1000):
        c.tick(0.002)
        if c.out_int[0] == DONE:
            break
    assert c.out_int[0] == DONE
    np.testing.assert_allclose(c.q, target, atol=1e-12)
    assert run_command(c, 0) == READY
    assert run_command(c, CMD_IS_STEADY) == DONE
    assert c.out_int[1] == 1


def test_async_movej_stopj_and_progress_register():
    c = FakeController(time_scale=1.0)
    c.start_program()
    run_command(c, 0)
    start = c.q.copy()
    target = start + np.array([1.0, 0, 0, 0, 0, 0])
    assert run_command(c, CMD_MOVEJ, ints=[(1, 1)], doubles=[*target, 0.5, 1.0]) == DONE
    assert c.out_int[2] & 32768  # async operation running
    run_command(c, 0, ticks=100)  # 0.2 s of motion
    assert run_command(c, CMD_IS_STEADY) == DONE and c.out_int[1] == 0
    run_command(c, 0)
    assert run_command(c, CMD_STOPJ, doubles=[2.0]) == DONE
    assert not c.moving
    assert not c.out_int[2] & 32768
    assert start[0] < c.q[0] < target[0]


def test_a_command_written_again_after_a_restart_runs():
    # The client writes moveJ while the program is stopped (its view of the
    # stream is late), clears it, restarts the program and sends moveJ again.
    # The clear may reach the controller only after the restart and the new
    # moveJ before the next cycle: the new package is still a new command.
    def move_package(target):
        values = {"input_int_register_0": CMD_MOVEJ, "input_int_register_1": 0}
        values.update({f"input_double_register_{i}": v for i, v in enumerate([*target, 1.0, 2.0])})
        return values

    c = FakeController(time_scale=10.0)
    c.start_program()
    c.stop_program()
    target = c.q + 0.2
    c.write_inputs(move_package(target))  # refused: no program runs
    c.start_program()
    c.tick(0.002)
    assert not c.moving  # what was left in the register is not run by the new program
    c.write_inputs({"input_int_register_0": 0})
    c.write_inputs(move_package(target))  # no cycle saw the clear
    c.tick(0.002)
    assert c.moving


def test_stop_script_and_upper_range_registers():
    c = FakeController()
    c.start_program(reg_offset=24)
    c.in_int[24] = CMD_STOP_SCRIPT
    c.tick(0.002)
    assert c.runtime_state == RUNTIME_STOPPED
    c.start_program(reg_offset=24)
    c.tick(0.002)
    assert c.out_int[24] == READY and c.out_int[0] == 0


def test_no_program_runs_while_safety_stopped():
    c = FakeController(unlock_delay_s=0.0)
    c.protective_stop()
    c.start_program()
    assert c.runtime_state == RUNTIME_STOPPED
    assert c.unlock_protective_stop() == "Protective stop releasing"
    c.start_program()
    assert c.runtime_state == RUNTIME_PLAYING


@pytest.mark.parametrize("travel, speed, accel", [(1.0, 0.5, 1.0), (0.01, 0.5, 1.0), (0.0, 1, 1)])
def test_joint_move_profile(travel, speed, accel):
    from drivers.robot.ur.device import expected_move_time

    q0 = np.zeros(6)
    q1 = np.array([travel, -travel / 2, 0, 0, 0, 0])
    move = _JointMove(q0, q1, speed, accel)
    assert move.duration == pytest.approx(expected_move_time(q0, q1, speed, accel))
    peak = 0.0
    steps = 0
    while not move.finished:
        _, qd = move.advance(0.001)
        peak = max(peak, abs(qd[0]))
        steps += 1  # a move that never finishes fails here, not hangs the run
        assert steps <= 1000 * move.duration + 10, "the move did not finish in its duration"
    assert peak <= speed + 1e-9
    q_end, _ = move.advance(0.0)
    np.testing.assert_allclose(q_end, q1, atol=1e-12)


def test_time_scale_must_be_positive():
    with pytest.raises(ValueError):
        FakeController(time_scale=0.0)


def test_launcher_replaces_a_leftover_fake(fake_manager):
    # a fake nobody stopped (e.g. from a crashed run) must not block the next one
    from drivers.robot.ur.simulator.launcher import FakeUrProcess

    leftover = fake_manager.running()
    fresh = FakeUrProcess(time_scale=10.0).start()
    try:
        leftover.process.wait(5)
        assert not leftover.running
        assert fresh.command("fake status") == "fake: status normal"
    finally:
        fresh.stop()
        fake_manager.discard()


def test_launcher_kills_a_hung_leftover(fake_manager):
    # a frozen fake still completes TCP handshakes but never answers "fake shutdown"
    import os
    import signal

    from drivers.robot.ur.simulator.launcher import FakeUrProcess

    fake_manager.discard()
    hung = FakeUrProcess(time_scale=10.0).start()
    os.kill(hung.process.pid, signal.SIGSTOP)
    try:
        fresh = FakeUrProcess(time_scale=10.0).start()
        try:
            assert hung.process.wait(5) == -signal.SIGKILL
            assert fresh.command("fake status") == "fake: status normal"
        finally:
            fresh.stop()
    finally:
        hung.stop()
