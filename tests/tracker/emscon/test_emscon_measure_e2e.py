"""``calibrator measure --tracker emscon://127.0.0.1:PORT`` with the simulated robot, then identify.

The emScon simulator runs as its own process; the simulated robot steers its
target through the control port (``--robot sim://?control=URL``), exactly as it
steers the embedded line-protocol simulator.
"""

from __future__ import annotations

import json

import numpy as np
import pyarrow.parquet as pq
from cli_process_kit import run_cli

from drivers.tracker.emscon.simulator import EmsconSimulatorProcess


def _cli(*args, cwd):
    return run_cli(*args, cwd=cwd)


def test_measure_over_emscon_records_a_session_identify_fits_to_the_noise_floor(tmp_path):
    with EmsconSimulatorProcess(seed=4, initialised=True) as sim:
        done = _cli(
            "measure", "--poses", "30", "--tracker", sim.url, "--robot", f"sim://?control={sim.control_url}",
            "-o", "s.parquet", "--yes", cwd=tmp_path,
        )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert "wrote s.parquet: 30 poses x 10 readings" in done.stdout
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.parquet"]

    table = pq.read_table(tmp_path / "s.parquet").to_pydict()
    assert table["pose"] == list(range(30)) and set(table["n_readings"]) == {10}
    spread = np.column_stack([table[c] for c in ("sx_mm", "sy_mm", "sz_mm")])
    floor = float(np.sqrt(np.mean(np.sum(spread**2, axis=1)) / 10))  # noise left in a mean
    assert 0.001 < floor < 0.02

    ident = _cli("identify", "s.parquet", "-o", "cal.json", cwd=tmp_path)
    assert ident.returncode == 0, ident.stderr
    held_out = json.loads((tmp_path / "cal.json").read_text())["stats"]["validation"]
    assert held_out["before"]["position_mm"]["mean"] > 0.3  # hidden errors visible
    assert held_out["after"]["position_mm"]["mean"] < 2.5 * floor  # and fitted away


def test_measure_refuses_an_uninitialised_emscon_tracker_without_moving_its_head(tmp_path):
    with EmsconSimulatorProcess(seed=4, initialised=False) as sim:
        done = _cli(
            "measure", "--poses", "12", "--tracker", sim.url, "--robot", f"sim://?control={sim.control_url}",
            "-o", "s.parquet", "--yes", cwd=tmp_path,
        )  # fmt: skip
    assert done.returncode == 2
    assert "not initialised" in done.stderr and "Traceback" not in done.stderr
    assert list(tmp_path.iterdir()) == []  # no session, no journal


def test_measure_rejects_a_bad_emscon_url_in_one_line(tmp_path):
    done = _cli("measure", "--tracker", "emscon://", "-o", "s.parquet", "--yes", cwd=tmp_path)
    assert done.returncode == 2
    assert "emscon://HOST[:PORT]" in done.stderr and done.stderr.count("\n") == 1
