"""The history commands end to end: import, the table, CSV, page, reidentify, and refusals."""

import csv
import io
import json
import shutil

from cli_kit import cli, listing, one_line_error

from calibrator.history import open_history

ROBOT = "sim:er10l-c10:seed=3"


def test_import_then_table_and_csv(tmp_path, measured):
    history = tmp_path / "h.sqlite"
    result = cli("history", "import", measured, "--history", history, cwd=tmp_path)
    assert result.code == 0, result.stderr
    assert "3 sessions, 3 calibrations, 1 verifications, 0 checks" in result.stdout
    # Importing again adds nothing.
    assert cli("history", "import", measured, "--history", history, cwd=tmp_path).code == 0
    robots = cli("history", "--history", history, cwd=tmp_path)
    assert robots.stdout.splitlines()[1].split() == [ROBOT, "er10l-c10", "3"]
    shown = cli("history", ROBOT, "--history", history, "--csv", "t.csv", cwd=tmp_path)
    assert shown.code == 0, shown.stderr
    rows = list(csv.DictReader(io.StringIO((tmp_path / "t.csv").read_text())))
    assert [r["record"] for r in rows].count("calibration") == 3
    assert [r["record"] for r in rows].count("session") == 3
    assert [r["record"] for r in rows].count("iso9283 nominal") == 1
    held = [
        json.loads((measured / f"cal{i}.json").read_text())["stats"]["validation"]["after"]
        for i in range(3)
    ]
    assert sorted(float(r["held_out_mm"]) for r in rows if r["record"] == "calibration") == sorted(
        h["position_mm"]["mean"] for h in held
    )
    assert shown.stdout.count("calibration ") == 3


def test_identify_records_with_history(tmp_path, measured):
    shutil.copy(measured / "s0.parquet", tmp_path / "s.parquet")
    result = cli(
        "identify", "s.parquet", "-o", "c.json", "--method", "lm", "--history", "h.sqlite",
        cwd=tmp_path,
    )  # fmt: skip
    assert result.code == 0, result.stderr
    assert "recorded calibration 1 in the history h.sqlite" in result.stdout
    with open_history(tmp_path / "h.sqlite") as h:
        (cal,) = h.calibrations(ROBOT)
        assert cal["parameters"] == json.loads((tmp_path / "c.json").read_text())["deltas"]


def test_verify_records_with_history(measured):
    doc = json.loads((measured / "verify.json").read_text())
    with open_history(measured / "verify-history.sqlite", create=False) as h:
        (test,) = h.verifications(ROBOT)
    assert test["document"] == doc and test["compensated"] is False
    assert test["rp_mm"] == max(p["RP_mm"] for p in doc["poses"])


def test_refusals_are_one_line(tmp_path, measured):
    assert "no history at" in one_line_error(
        cli("history", "--history", tmp_path / "none.sqlite", cwd=tmp_path)
    )
    history = tmp_path / "h.sqlite"
    cli("history", "import", measured, "--history", history, cwd=tmp_path)
    assert "no robot 'arm-9'" in one_line_error(
        cli("history", "arm-9", "--history", history, cwd=tmp_path)
    )
    assert "not a folder" in one_line_error(
        cli("history", "import", tmp_path / "nope", "--history", history, cwd=tmp_path)
    )
    assert "give a date YYYY-MM-DD" in one_line_error(
        cli("history", "tracker", "x:y:z", "--certificate", "1.2.2026", "--history", history,
            cwd=tmp_path)
    )  # fmt: skip
    before = listing(tmp_path)
    # The history itself is never an output.
    line = one_line_error(
        cli("history", ROBOT, "--history", history, "--csv", history, cwd=tmp_path)
    )
    assert "h.sqlite" in line
    assert listing(tmp_path) == before
    bad = one_line_error(
        cli("identify", measured / "s0.parquet", "-o", "c.json", "--method", "lm",
            "--history", tmp_path / "no" / "h.sqlite", cwd=tmp_path)
    )  # fmt: skip
    # Refused before its work, as check refuses before measuring (issue 41).
    assert "folder" in bad and "does not exist" in bad
    assert not (tmp_path / "c.json").exists()


def test_reidentify_gives_what_identify_gives(tmp_path, measured):
    history = tmp_path / "h.sqlite"
    for i in range(3):
        shutil.copy(measured / f"s{i}.parquet", tmp_path / f"s{i}.parquet")
    with open_history(history) as h:
        for i in range(3):
            h.record_session(tmp_path / f"s{i}.parquet")
    options = "--generations 30 --seed 4"
    runs = {}
    for name, extra in (("here", ()), ("dask", ("--workers", "2"))):
        result = cli(
            "history", "reidentify", "--history", history, "-o", name, "-q",
            "--identify-options", options, *extra, cwd=tmp_path,
        )  # fmt: skip
        assert result.code == 0, result.stderr
        assert "identified 3 of 3 sessions again" in result.stdout
        runs[name] = sorted((tmp_path / name).glob("*.json"))
    for i, (here, dask) in enumerate(zip(runs["here"], runs["dask"], strict=True)):
        one = tmp_path / f"one{i}.json"
        session = tmp_path / f"s{i}.parquet"
        assert cli("identify", session, "-o", one, "-q", *options.split(), cwd=tmp_path).code == 0
        expected = json.loads(one.read_text())
        del expected["created"]  # the time it was made: the one key that differs
        for got in (here, dask):
            doc = json.loads(got.read_text())
            del doc["created"]
            assert doc == expected
    from calibrator.calibration import digest

    with open_history(history) as h:
        recorded = h.calibrations(ROBOT)
    # Every file written is recorded (two runs of a session in the same second
    # write the same bytes: one record), each with its session.
    assert {c["sha256"] for c in recorded} == {digest(f) for f in runs["here"] + runs["dask"]}
    assert len({c["session_id"] for c in recorded}) == 3
    again = cli("history", "reidentify", "--history", history, "-o", "here", cwd=tmp_path)
    assert "exists: choose another -o folder" in one_line_error(again)


def test_reidentify_refuses_identify_options_identify_refuses_before_any_work(tmp_path, measured):
    history = tmp_path / "h.sqlite"
    shutil.copy(measured / "s0.parquet", tmp_path / "s0.parquet")
    with open_history(history) as h:
        h.record_session(tmp_path / "s0.parquet")
    for options, says in (
        ("--particles 1", "--particles: must be a whole number >= 2, got 1"),
        ("--method newton", "'newton' is not one of"),
        ("--k 1 --orientation-weight 2", "give --orientation-weight only"),
    ):
        asked = ("history", "reidentify", "--history", history, "-o", "out", "--identify-options")
        line = one_line_error(cli(*asked, options, cwd=tmp_path))
        assert line.startswith(f"calibrator: error: --identify-options {options!r}: "), line
        assert says in line
        assert not (tmp_path / "out").exists()


def test_reidentify_on_a_running_scheduler(tmp_path, measured):
    """--scheduler: a cluster someone else started (here a local one, by its address)."""
    from calibrator.analysis import engine

    history = tmp_path / "h.sqlite"
    shutil.copy(measured / "s1.parquet", tmp_path / "s1.parquet")
    with open_history(history) as h:
        h.record_session(tmp_path / "s1.parquet")
    cluster = engine.local_cluster(1)
    try:
        result = cli(
            "history", "reidentify", "--history", history, "-o", "out", "-q",
            "--identify-options", "--method lm", "--scheduler", cluster.scheduler_address,
            cwd=tmp_path,
        )  # fmt: skip
    finally:
        cluster.close()
    assert result.code == 0, result.stderr
    (written,) = (tmp_path / "out").glob("*.json")
    assert cli("identify", tmp_path / "s1.parquet", "-o", "one.json", "--method", "lm",
               cwd=tmp_path).code == 0  # fmt: skip
    got, expected = json.loads(written.read_text()), json.loads((tmp_path / "one.json").read_text())
    del got["created"], expected["created"]
    assert got == expected
    both = cli("history", "reidentify", "--history", history, "--workers", "1",
               "--scheduler", "tcp://127.0.0.1:1", cwd=tmp_path)  # fmt: skip
    assert "give --workers or --scheduler, not both" in one_line_error(both)
