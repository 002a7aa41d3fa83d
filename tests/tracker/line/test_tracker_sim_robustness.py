"""The simulator survives its own wire and CLI (issue 8, item 5).

Bad ``SIM,FAULT`` lines and bad arguments get an ``ER`` reply and the
simulator keeps serving; a bad command line gets one line on stderr and
exit 2, never a traceback.
"""

from __future__ import annotations

import socket
import subprocess
import sys
import time

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from tracker_kit import REPO, host

from drivers.tracker.instrument.faults import parse_fault, parse_script
from drivers.tracker.line.protocol import decode_frame, parse_reply
from drivers.tracker.line.simulator import SimulatorServer, TrackerSimulator

BAD_FAULTS = [
    "MEAS+1 error code=FOO",
    "MEAS+1 error code=",
    "MEAS+1 error code=999",
    "MEAS+1 delay delay=inf",
    "MEAS+1 delay delay=nan",
    "MEAS+1 delay delay=-1",
    "MEAS+1 delay delay=1e3",
    "MEAS+1 delay delay=100000",
    "MEAS+1 partial delay=nan",
    "MEAS+1 unstable count=x",
    "MEAS+1 unstable count=0",
    "MEAS+1 unstable count=99999999999999999999",
    "MEAS+1 garble extra",
    "MEAS+99999999999999999999 drop",
    "MEAS+1",
]


@pytest.mark.parametrize("line", BAD_FAULTS)
def test_bad_fault_line_is_a_value_error(line):
    with pytest.raises(ValueError):
        parse_fault(line)


def _reply(sim, seq, *fields):
    (out,) = sim.handle_line(host(seq, *fields))
    return parse_reply(decode_frame(out.data))


@pytest.mark.parametrize("line", BAD_FAULTS)
def test_bad_sim_fault_gets_bad_parameter_and_the_simulator_goes_on(line):
    sim = TrackerSimulator(seed=1, initialised=True)
    sim.set_target([2000.0, 0.0, 0.0])
    reply = _reply(sim, 1, "SIM", "FAULT", line)
    assert reply.kind.value == "ER" and reply.text == "BAD_PARAMETER"
    assert _reply(sim, 2, "MEAS").kind.value == "OK"  # nothing was armed


@pytest.mark.parametrize(
    "fields",
    [
        ("SIM", "TARGET", "1e3", "0.0", "0.0"),
        ("SIM", "TARGET", "inf", "0.0", "0.0"),
        ("SIM", "TARGET", "nan", "0.0", "0.0"),
        ("ENV", "nan", "1013.25", "50.0"),
        ("ENV", "2_0.0", "1013.25", "50.0"),
        ("ENV", "20"),
        ("SIM",),
        ("UNITS",),
    ],
)
def test_bad_arguments_get_an_error_reply(fields):
    sim = TrackerSimulator(seed=1, initialised=True)
    reply = _reply(sim, 1, *fields)
    assert reply.kind.value == "ER"


@settings(max_examples=200, deadline=None)
@given(st.text(alphabet=st.characters(min_codepoint=32, max_codepoint=126), max_size=60))
def test_any_sim_fault_text_gets_a_reply(text):
    sim = TrackerSimulator(seed=1, initialised=True)
    text = text.replace(",", ";").replace("*", "x")
    outputs = sim.handle_line(host(1, "SIM", "FAULT", text))
    assert len(outputs) == 1
    reply = parse_reply(decode_frame(outputs[0].data))
    assert reply.seq == 1


def _exchange(sock, seq, *fields, timeout=2.0):
    sock.sendall(host(seq, *fields))
    sock.settimeout(timeout)
    buf = b""
    deadline = time.monotonic() + 5 * timeout  # a reply that never ends fails, not hangs
    while not buf.endswith(b"\r\n"):
        assert time.monotonic() < deadline, f"no whole reply in {5 * timeout:g} s: {buf[-99:]!r}"
        buf += sock.recv(4096)
    return parse_reply(decode_frame(buf))


@pytest.mark.parametrize("line", ["MEAS+1 delay delay=inf", "MEAS+1 delay delay=nan"])
def test_served_simulator_survives_bad_delays(line):
    sim = TrackerSimulator(seed=1, initialised=True)
    sim.set_target([2000.0, 0.0, 0.0])
    with SimulatorServer(sim) as server:
        port = server.open_tcp(0)
        server.start()
        with socket.create_connection(("127.0.0.1", port), timeout=2) as sock:
            assert _exchange(sock, 1, "SIM", "FAULT", line).kind.value == "ER"
            started = time.monotonic()
            assert _exchange(sock, 2, "MEAS").kind.value == "OK"
            assert time.monotonic() - started < 1.0


def test_parse_script_names_the_line():
    with pytest.raises(ValueError, match="line 2"):
        parse_script("MEAS@1 drop\nMEAS@2 error code=FOO\n")


# ---------------------------------------------------------------- command line


def _run_cli(*args, timeout=20):
    return subprocess.run(
        [sys.executable, "-m", "drivers.tracker.line.simulator", *args],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=timeout,
    )


@pytest.mark.parametrize(
    "make_args",
    [
        lambda tmp: ["--tcp", "99999"],
        lambda tmp: ["--tcp", "-1"],
        lambda tmp: ["--tcp", "abc"],
        lambda tmp: ["--tcp", "0", "--faults", str(tmp / "missing.txt")],
        lambda tmp: ["--tcp", "0", "--faults", _write(tmp / "f.txt", "MEAS@1 error code=FOO")],
        lambda tmp: ["--tcp", "0", "--faults", _write(tmp / "g.txt", "MEAS@1 delay delay=inf")],
        lambda tmp: ["--tcp", "0", "--faults", str(tmp)],
        lambda tmp: ["--tcp", "0", "--replay", str(tmp / "missing.jsonl")],
        lambda tmp: ["--tcp", "0", "--replay", _write(tmp / "r.jsonl", "not json\n")],
        lambda tmp: ["--tcp", "0", "--serial", "A,B"],
        lambda tmp: ["--tcp", "0", "--serial", "A*B"],
        lambda tmp: ["--tcp", "0", "--target", "1e3,0,0"],
        lambda tmp: ["--tcp", "0", "--target", "nan,0,0"],
        lambda tmp: ["--tcp", "0", "--init-time", "nan"],
        lambda tmp: ["--tcp", "0", "--seed", "-1"],
        lambda tmp: [],
    ],
)
def test_bad_command_line_gives_one_line_and_exit_2(tmp_path, make_args):
    result = _run_cli(*make_args(tmp_path))
    assert result.returncode == 2, result.stderr
    assert "Traceback" not in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1, result.stderr
    assert result.stdout == ""


def _write(path, text):
    path.write_text(text)
    return str(path)
