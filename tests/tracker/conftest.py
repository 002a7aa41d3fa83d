"""Fixtures that start simulated trackers: in-process (thread) and as a separate process."""

from __future__ import annotations

import subprocess
import sys

import pytest
from timeout_kit import readline
from tracker_kit import REPO

from drivers.tracker.line.simulator import SimulatorServer, TrackerSimulator


@pytest.fixture
def sim():
    """An initialised, seeded simulator with a target 2 m away, not yet served."""
    simulator = TrackerSimulator(seed=11, initialised=True, init_time_s=0.05)
    simulator.set_target([2000.0, 300.0, -200.0])
    return simulator


@pytest.fixture
def served(sim):
    """``(sim, pty_path, tcp_url)``: ``sim`` served over a pty and 127.0.0.1 TCP in a thread."""
    server = SimulatorServer(sim)
    path = server.open_pty()
    port = server.open_tcp(0)
    server.start()
    yield sim, path, f"socket://127.0.0.1:{port}"
    server.stop()


def start_simulator_process(*args: str) -> tuple[subprocess.Popen, list[str]]:
    """Run ``python -m drivers.tracker.line.simulator *args``; return it and its endpoint lines."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "drivers.tracker.line.simulator", *args],
        cwd=REPO,
        stdout=subprocess.PIPE,
        text=True,
    )
    n_lines = ("--pty" in args) + ("--tcp" in args)
    try:
        lines = [readline(proc.stdout, what="endpoint").strip() for _ in range(n_lines)]
    except AssertionError:
        proc.kill()
        raise
    if not all(lines):
        proc.kill()
        raise RuntimeError(f"simulator did not start: {lines}")
    return proc, lines


@pytest.fixture
def sim_process(request):
    """Factory fixture: start simulator processes, terminated at teardown."""
    procs = []

    def start(*args: str):
        proc, lines = start_simulator_process(*args)
        procs.append(proc)
        return proc, lines

    yield start
    for proc in procs:
        if proc.poll() is None:
            proc.terminate()
            try:
                proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                proc.kill()
        proc.stdout.close()
