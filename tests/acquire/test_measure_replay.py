"""Replay: a recorded tracker exchange, answered by the simulator, gives the same session back.

``fixtures/measure/`` holds a small session measured on the simulated cell
(9 poses x 5 readings, a beam break in pose 4) and the raw tracker exchange
recorded by the driver; regenerate both with the command in docs/measure.md.
"""

from pathlib import Path

import pyarrow.parquet as pq
from cli_process_kit import run_cli

from drivers.tracker import read_log

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "measure"
COLUMNS = ("pose", "q1_rad", "q6_rad", "x_mm", "y_mm", "z_mm", "sx_mm", "sz_mm", "n_readings")


def fixture_plan(folder):
    """The recorded session's joints as a plan file in ``folder``: the replay measures
    exactly those poses, whatever the planner would choose today."""
    import numpy as np

    from calibrator import planning

    table = pq.read_table(FIXTURES / "session.parquet").to_pydict()
    planning.write_plan(
        folder / "plan.csv", planning.Plan(np.array([table[f"q{i}_rad"] for i in range(1, 7)]).T)
    )
    return folder / "plan.csv"


def test_replayed_exchange_gives_the_recorded_session_row_for_row(tmp_path):
    done = run_cli(
        "measure",
        "--plan",
        fixture_plan(tmp_path),
        "--readings",
        "5",
        # noise off: a live simulator would now differ; the replay cannot
        "--tracker",
        f"sim://?noise=off&replay={FIXTURES / 'exchange.jsonl'}&record=again.jsonl",
        "-o",
        "s.parquet",
        cwd=tmp_path,
    )
    assert done.returncode == 0, done.stderr
    replayed = pq.read_table(tmp_path / "s.parquet").to_pydict()
    recorded = pq.read_table(FIXTURES / "session.parquet").to_pydict()
    for column in COLUMNS:
        assert replayed[column] == recorded[column], column
    # The beam break replayed too: pose 4's set was taken twice (45 + 5 MEAS).
    sent = [e.data for e in read_log(tmp_path / "again.jsonl") if e.direction == "tx"]
    assert sum(b",MEAS*" in line for line in sent) == 50
    original = [e.data for e in read_log(FIXTURES / "exchange.jsonl") if e.direction == "tx"]
    assert sent == original
