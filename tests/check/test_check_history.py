"""``check --history FILE`` records the check in the calibration history (calibrator.history).

The history lives on another branch; this test runs once both are merged.
"""

import json

import pytest
from cli_kit import cli, one_line_error

history = pytest.importorskip("calibrator.history")


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    folder = tmp_path_factory.mktemp("hist")
    done = cli("measure", "--model", "ur10e", "--seed", "3", "--poses", "30", "-o", "s.parquet",
               "-q", cwd=folder)  # fmt: skip
    assert done.code == 0, done.stderr
    assert cli("identify", "s.parquet", "-o", "cal.json", "-q", cwd=folder).code == 0
    return folder


def test_a_check_is_recorded_and_reads_back(calibrated):
    folder = calibrated
    db = folder / "history.sqlite"
    done = cli(
        "check", "--model", "ur10e", "--seed", "3", "--calibration", "cal.json", "-o", "c.json",
        "--history", db, cwd=folder,
    )  # fmt: skip
    assert done.code == 0, done.stderr
    assert "recorded check 1 in" in done.stdout
    doc = json.loads((folder / "c.json").read_text())
    with history.open_history(db) as store:
        (row,) = store.checks(doc["robot"])
    assert row["verdict"] == "ok" and row["calibration_sha256"] == doc["calibration_sha256"]
    assert row["measured_mm"] == pytest.approx(doc["measured_mm"])
    assert row["pose_errors_mm"] == pytest.approx(doc["pose_errors_mm"])


def test_a_history_that_is_not_one_is_refused_in_one_line(calibrated):
    folder = calibrated
    (folder / "not.sqlite").write_text("not a database\n")
    result = cli(
        "check", "--model", "ur10e", "--seed", "3", "--calibration", "cal.json", "-o", "d.json",
        "--history", "not.sqlite", cwd=folder,
    )  # fmt: skip
    assert "not.sqlite" in one_line_error(result)
    assert not (folder / "d.json").exists()  # refused before the arm moved
