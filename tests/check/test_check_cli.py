"""``calibrator check`` on the simulated cell: its outputs, and bad input refused in one line."""

import json

import pytest
from cli_kit import cli, listing, one_line_error


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    folder = tmp_path_factory.mktemp("check")
    done = cli("measure", "--model", "ur10e", "--seed", "3", "--poses", "30", "-o", "s.parquet",
               "-q", cwd=folder)  # fmt: skip
    assert done.code == 0, done.stderr
    assert cli("identify", "s.parquet", "-o", "cal.json", "-q", cwd=folder).code == 0
    base = cli("simulate", "-o", "b.parquet", "--model", "ur10e", "--errors", "random",
               cwd=folder)  # fmt: skip
    assert base.code == 0, base.stderr
    assert cli("identify", "b.parquet", "-o", "base.json", "-q", cwd=folder).code == 0
    doc = json.loads((folder / "cal.json").read_text())
    doc["uncertainty"] = {}  # as a calibration from before the uncertainty was recorded
    (folder / "bare.json").write_text(json.dumps(doc))
    return folder


def test_a_check_writes_its_verdict_and_poses_and_says_the_cell_time_first(calibrated):
    folder = calibrated
    done = cli("check", "--model", "ur10e", "--seed", "3", "--calibration", "cal.json",
               "--poses", "6", "-o", "c.json", cwd=folder)  # fmt: skip
    assert done.code == 0, done.stderr
    assert done.stderr.startswith("estimated cell time: ")
    doc = json.loads((folder / "c.json").read_text())
    for key in ("robot", "time", "calibration_sha256", "verdict", "measured_mm", "predicted_mm",
                "pose_errors_mm", "poses", "explanation", "conditions"):  # fmt: skip
        assert key in doc, key
    assert doc["verdict"] == "ok" and len(doc["poses"]) == 6 and doc["dof"] == 18
    assert doc["conditions"]["tracker_warmed_up"] is True
    assert 0.5 < doc["measured_mm"] / doc["predicted_mm"] < 2.0
    assert "verdict: ok" in done.stdout and "wrote c.json and c.parquet" in done.stdout


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (("--calibration", "missing.json"), "missing.json"),
        (("--calibration", "base.json"), "identified in the robot base frame"),
        (("--calibration", "cal.json", "--model", "ur5e"), "--model ur5e but cal.json is of"),
        (("--calibration", "cal.json", "--poses", "4"), "--poses"),
        (("--calibration", "cal.json", "-o", "x.parquet"), "give the JSON file"),
        (("--calibration", "cal.json", "--world", "nope.yaml"), "nope.yaml"),
        (("--calibration", "bare.json"), "records no residual noise"),
    ],
)
def test_bad_input_is_refused_in_one_line_and_nothing_is_written(calibrated, args, message):
    folder = calibrated
    before = listing(folder)
    result = cli("check", "--model", "ur10e", *args, cwd=folder)  # a later --model wins
    assert message in one_line_error(result)
    assert listing(folder) == before
