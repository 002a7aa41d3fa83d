"""``check --session FILE``: a recorded re-check judged as a measured one.

A check measured on the simulated cell writes its poses as a session
(``check.parquet``); judging that file again with ``--session`` gives the
same verdict, figures and explanation, and the history files the check under
the time its poses were measured.
"""

import json

import pytest
from cli_kit import cli, one_line_error

history = pytest.importorskip("calibrator.history")

#: What a recorded check must reproduce of the measured one.
SAME = ("verdict", "measured_mm", "predicted_mm", "chi2", "dof", "p_value", "pose_errors_mm",
        "explanation", "explanation_text", "calibration_sha256", "robot", "tracker")  # fmt: skip


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    folder = tmp_path_factory.mktemp("recorded")
    (folder / "today.yaml").write_text("world: 1\nmodel: ur10e\nseed: 3\n")
    (folder / "crashed.yaml").write_text(
        "world: 1\nmodel: ur10e\nseed: 3\njoint_zero_shifts_rad: [0, 0, 0, 1.0e-3, 0, 0]\n"
    )
    done = cli("measure", "--model", "ur10e", "--world", "today.yaml", "--poses", "40",
               "-o", "s.parquet", "-q", cwd=folder)  # fmt: skip
    assert done.code == 0, done.stderr
    assert cli("identify", "s.parquet", "-o", "cal.json", "-q", cwd=folder).code == 0
    return folder


@pytest.mark.parametrize(("world", "code"), [("today.yaml", 0), ("crashed.yaml", 4)])
def test_a_recorded_check_says_what_the_measured_one_said(calibrated, world, code):
    folder = calibrated
    name = world.removesuffix(".yaml")
    measured = cli("check", "--model", "ur10e", "--calibration", "cal.json", "--world", world,
                   "--seed", "5", "-o", f"{name}.json", "-q", cwd=folder)  # fmt: skip
    assert measured.code == code, measured.stderr
    db = folder / f"{name}.sqlite"
    again = cli("check", "--calibration", "cal.json", "--session", f"{name}.parquet",
                "-o", f"{name}-again.json", "--history", db, cwd=folder)  # fmt: skip
    assert again.code == code, again.stderr
    first = json.loads((folder / f"{name}.json").read_text())
    second = json.loads((folder / f"{name}-again.json").read_text())
    for key in SAME:  # the same numbers in, the same figures out, bit for bit
        assert second[key] == first[key], key
    assert second["data"] == f"{name}.parquet"
    if code:
        assert second["explanation_text"][0].startswith("joint 4 zero moved +1.0")
    # The printed verdict is the measured check's.
    said = [s for s in again.stdout.splitlines() if s.startswith(("measured ", "verdict", "  "))]
    told = [s for s in measured.stdout.splitlines() if s.startswith(("measured ", "verdict", "  "))]
    assert said == told
    # Filed under when its poses were measured (the measured check's first pose).
    with history.open_history(db) as store:
        (row,) = store.checks(first["robot"])
    started = history.records.utc(first["conditions"]["started"], "started")
    assert row["time"] == started and row["verdict"] == first["verdict"]
    assert first["measured_at"] == first["conditions"]["started"]


def test_what_a_recorded_check_refuses(calibrated, tmp_path):
    folder = calibrated
    (tmp_path / "not.parquet").write_text("not a session\n")
    cases = [
        (["--session", tmp_path / "not.parquet"], "not.parquet"),
        (["--session", tmp_path / "missing.parquet"], "missing.parquet"),
        (["--session", "s.parquet", "--world", "today.yaml"], "--world is for a measured check"),
        (["--session", "s.parquet", "-o", tmp_path / "x.parquet"], "give the JSON file"),
    ]
    for extra, said in cases:
        result = cli("check", "--calibration", "cal.json", *extra, cwd=folder)
        assert said in one_line_error(result), extra
    assert not (folder / "check.json").exists()
    # A session in the robot base frame cannot be compared with tracker readings.
    done = cli("simulate", "--model", "ur10e", "-o", tmp_path / "base.parquet", cwd=folder)
    assert done.code == 0, done.stderr
    result = cli("check", "--calibration", "cal.json", "--session", tmp_path / "base.parquet",
                 "-o", tmp_path / "b.json", cwd=folder)  # fmt: skip
    assert "in the base frame" in one_line_error(result)
    assert not (tmp_path / "b.json").exists()
