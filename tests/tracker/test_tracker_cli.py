"""``calibrator tracker status|init``: set a tracker up from the shell, then measure with it.

Both tracker kinds are started uninitialised (as the simulators start by
default); ``init`` asks first (or takes ``--yes``), and afterwards
``measure`` runs on them with the simulated robot steering the simulator.
"""

import subprocess

import pytest
from cli_process_kit import run_cli

from drivers.tracker.emscon.simulator import EmsconSimulatorProcess
from drivers.tracker.line.simulator import SimulatorProcess

KINDS = [SimulatorProcess, EmsconSimulatorProcess]


def one_line(done):
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in done.stderr, done.stderr
    return lines[0]


@pytest.mark.parametrize("simulator", KINDS, ids=["line", "emscon"])
def test_init_asks_first_then_measure_needs_no_python(simulator, tmp_path):
    with simulator(noise=False, initialised=False) as sim:
        status = run_cli("tracker", "status", "--tracker", sim.url)
        assert status.returncode == 0, status.stderr
        assert "initialised=False" in status.stdout
        measure = ("measure", "--poses", "12", "--robot", f"sim://?control={sim.control_url}", "-q")
        refused = run_cli(*measure, "--tracker", sim.url, "-o", "a.parquet", cwd=tmp_path)
        assert refused.returncode == 2
        assert f"run `calibrator tracker init --tracker {sim.url}`" in one_line(refused)
        asked = run_cli("tracker", "init", "--tracker", sim.url, stdin=subprocess.DEVNULL)
        assert asked.returncode == 2
        assert one_line(asked).endswith("moves its head: pass --yes to confirm")
        assert "initialised=False" in run_cli("tracker", "status", "--tracker", sim.url).stdout
        done = run_cli("tracker", "init", "--tracker", sim.url, "--yes")
        assert done.returncode == 0, done.stderr
        assert done.stdout.strip().endswith(": initialised")
        again = run_cli("tracker", "init", "--tracker", sim.url)  # nothing to do, nothing asked
        assert again.returncode == 0 and again.stdout.strip().endswith(": already initialised")
        assert "initialised=True" in run_cli("tracker", "status", "--tracker", sim.url).stdout
        measured = run_cli(*measure, "--tracker", sim.url, "-o", "s.parquet", cwd=tmp_path)
        assert measured.returncode == 0, measured.stderr
        assert measured.stdout.startswith("wrote s.parquet: 12 poses")


@pytest.mark.parametrize(
    ("url", "message"),
    [
        ("socket://127.0.0.1:1", "tracker at socket://127.0.0.1:1: "),
        ("gopher://x", "--tracker: unknown tracker 'gopher://x'"),
        ("sim", "--tracker sim is started by measure itself"),
    ],
)
@pytest.mark.parametrize("command", ["status", "init"])
def test_a_bad_tracker_url_is_one_line_exit_2(command, url, message):
    extra = ("--yes",) if command == "init" else ()
    done = run_cli("tracker", command, "--tracker", url, *extra)
    assert done.returncode == 2
    assert one_line(done).startswith(f"calibrator: error: {message}")
