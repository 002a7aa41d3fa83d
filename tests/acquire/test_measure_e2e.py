"""``calibrator measure`` end to end on the embedded simulated cell, then ``identify``."""

import json

import numpy as np
import pyarrow.parquet as pq
from cli_process_kit import run_cli


def test_measure_then_identify_recovers_hidden_errors_to_noise_floor(tmp_path):
    done = run_cli("measure", "--poses", "30", "-o", "s.parquet", "--yes", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert "wrote s.parquet: 30 poses x 10 readings" in done.stdout
    assert not (tmp_path / "s.parquet.journal").exists()  # finished: nothing to resume
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.parquet"]  # no temp files

    table = pq.read_table(tmp_path / "s.parquet").to_pydict()
    assert table["pose"] == list(range(30)) and set(table["n_readings"]) == {10}
    spread = np.column_stack([table[c] for c in ("sx_mm", "sy_mm", "sz_mm")])
    # The noise left in a mean of 10 readings: its RMS 3-D size, mm.
    floor = float(np.sqrt(np.mean(np.sum(spread**2, axis=1)) / 10))
    assert 0.001 < floor < 0.02

    ident = run_cli("identify", "s.parquet", "-o", "cal.json", cwd=tmp_path)
    assert ident.returncode == 0, ident.stderr
    held_out = json.loads((tmp_path / "cal.json").read_text())["stats"]["validation"]
    before = held_out["before"]["position_mm"]["mean"]
    after = held_out["after"]["position_mm"]["mean"]
    assert before > 0.3  # the hidden errors are visible with the nominal model
    assert after < 2.5 * floor, (after, floor)  # and gone down to the noise


def test_the_default_run_gives_identify_enough_values_per_parameter(tmp_path):
    """measure's default plan size does not make identify warn of too few values."""
    done = run_cli("measure", "-o", "s.parquet", "--yes", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    ident = run_cli("identify", "s.parquet", "-o", "c.json", cwd=tmp_path)
    assert ident.returncode == 0, ident.stderr
    assert "per parameter" not in ident.stderr, ident.stderr


def test_plan_and_measure_state_one_cell_time_for_one_plan(tmp_path):
    """The simulated cell does not settle; the real arm plan estimates does: both said."""
    made = run_cli("plan", "--poses", "12", "-o", "p.csv", cwd=tmp_path)
    assert made.returncode == 0, made.stderr
    planned = made.stdout.split("estimated cell time ", 1)[1].split(" at ", 1)[0]
    done = run_cli("measure", "--plan", "p.csv", "-o", "s.parquet", "--yes", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    said = (done.stdout + done.stderr).split("(as plan estimates): ", 1)[1].splitlines()[0]
    assert said == planned
