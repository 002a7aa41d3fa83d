"""``check --circle --history``: the quick circle test as a history record of its own.

One real circle test of seed 3's calibrated arm, recorded by the command into
an SQLite history; the same document recorded into every backend (SQLite,
PostgreSQL), imported from a folder, shown by ``history ROBOT`` (text, CSV,
page), refused when a figure is missing; and a history of the previous
schema (0004) gains the table on opening.
"""

from __future__ import annotations

import csv
import io
import json

import pytest
from cli_kit import cli, one_line_error

from calibrator.history import HistoryError, migrations, open_history, records, store

pytestmark = pytest.mark.timeout(900)

ROBOT = "sim:ur10e:seed=3"


@pytest.fixture(scope="module")
def circled(tmp_path_factory):
    """Seed 3 measured, identified, and its circle test run and recorded by the command."""
    folder = tmp_path_factory.mktemp("circled")
    for args in (
        ("measure", "-q", "--seed", "3", "--poses", "60", "-o", "s.parquet"),
        ("identify", "s.parquet", "-o", "cal.json"),
    ):
        done = cli(*args, cwd=folder)
        assert done.code == 0, done.stderr
    done = cli(
        "check", "--circle", "--seed", "3", "--calibration", "cal.json", "--circle-speed", "400",
        "-o", "circle.json", "--history", "h.db", cwd=folder,
    )  # fmt: skip
    assert done.code == 0, done.stderr
    assert "recorded circle check 1 in h.db" in done.stdout
    return folder


def _doc(folder):
    return json.loads((folder / "circle.json").read_text())


def test_the_command_records_the_circle_figures_and_verdict(circled):
    doc = _doc(circled)
    circle = doc["circle"]
    assert doc["robot"] == ROBOT and doc["tracker"] and doc["time"].endswith("Z")
    with open_history(str(circled / "h.db")) as h:
        rows = h.circle_checks(ROBOT)
        assert h.checks(ROBOT) == []  # the pose checks' table is untouched
    assert len(rows) == 1
    row = rows[0]
    assert row["verdict"] == circle["verdict"] == "ok"
    assert row["radius_error_mm"] == circle["radius_error_mm"]
    assert row["out_of_roundness_mm"] == circle["out_of_roundness_mm"]
    assert row["reversal_mm"] == circle["reversal_mm"]
    assert row["centre_offset_mm"] == circle["centre_offset_norm_mm"]
    assert row["direction_gap_mm"] == circle["direction_gap_mm"]
    assert row["radius_mm"] == circle["commanded"]["radius_mm"] and row["speed_mm_s"] == 400.0
    assert row["calibration_sha256"] == doc["calibration_sha256"] and row["compensated"] is True
    assert row["document"] == doc and row["tracker"] == doc["tracker"]
    assert row["time"].isoformat() + "Z" == doc["time"]


def test_history_lists_the_circle_check_in_its_table_csv_and_page(circled):
    circle = _doc(circled)["circle"]
    done = cli(
        "history", ROBOT, "--history", "h.db", "--csv", "t.csv", "--html", "page", cwd=circled
    )
    assert done.code == 0, done.stderr
    line = next(x for x in done.stdout.splitlines() if "circle check" in x)
    assert " ok " in line + " "
    assert f"out-of-roundness {circle['out_of_roundness_mm']:.4f}" in line
    assert f"reversal {circle['reversal_mm']:.4f}" in line
    rows = list(csv.DictReader(io.StringIO((circled / "t.csv").read_text())))
    row = next(r for r in rows if r["record"] == "circle check")
    assert float(row["radius_error_mm"]) == circle["radius_error_mm"]
    assert float(row["out_of_roundness_mm"]) == circle["out_of_roundness_mm"]
    assert row["verdict"] == "ok"
    page = (circled / "page" / "index.html").read_text()
    section = page[page.index('id="circle-checks"') : page.index('id="path-tests"')]
    assert f"<td>{circle['out_of_roundness_mm']:.4f}</td>" in section
    assert "<td>ok</td>" in section and "<th>circle checks</th><td>1</td>" in page


def test_the_same_document_is_one_record_on_every_backend(circled, history_url):
    doc = _doc(circled)
    with open_history(history_url) as h:
        first = h.record_circle_check(doc)
        again = h.record_circle_check(json.loads(json.dumps(doc)))
        assert first == again
        rows = h.circle_checks(ROBOT)
    assert len(rows) == 1 and rows[0]["document"] == doc
    assert rows[0]["out_of_roundness_mm"] == doc["circle"]["out_of_roundness_mm"]


@pytest.mark.parametrize(
    "change, message",
    [
        (lambda d: d["circle"].pop("out_of_roundness_mm"), "'out_of_roundness_mm' must be"),
        (lambda d: d.update(verdict="drifted"), "'verdict' must be one of ok, flagged"),
        (lambda d: d.pop("robot"), "'robot' must be the robot's name"),
        (lambda d: d.update(format="calibrator.check"), "is not a calibrator check --circle file"),
    ],
)
def test_a_circle_document_missing_a_figure_is_refused_and_nothing_written(
    circled, history_url, change, message
):
    doc = _doc(circled)
    change(doc)
    with open_history(history_url) as h:
        with pytest.raises(HistoryError, match=message):
            h.record_circle_check(doc)
        assert h.robots() == []  # not even its robot


def test_import_finds_circle_files_beside_the_others(circled, tmp_path):
    folder = tmp_path / "files"
    folder.mkdir()
    (folder / "circle.json").write_text((circled / "circle.json").read_text())
    done = cli("history", "import", "files", "--history", "i.db", cwd=tmp_path)
    assert done.code == 0, done.stderr
    assert "1 circle checks" in done.stdout
    with open_history(str(tmp_path / "i.db")) as h:
        assert [r["verdict"] for r in h.circle_checks(ROBOT)] == ["ok"]


def test_an_unusable_history_is_refused_before_the_circle_runs(circled, tmp_path):
    (tmp_path / "not.db").write_text("not a database\n")
    done = cli(
        "check", "--circle", "--seed", "3", "--calibration", circled / "cal.json",
        "-o", "c.json", "--history", "not.db", cwd=tmp_path,
    )  # fmt: skip
    one_line_error(done)
    assert not (tmp_path / "c.json").exists()


def test_a_history_at_0004_gains_the_circle_table_on_opening(circled, tmp_path):
    url = str(tmp_path / "old.db")
    engine = store._engine(store.resolve(url), create=True)
    with engine.begin() as conn:
        migrations.upgrade(conn, "0004")
        assert "circle_checks" not in _tables(conn)
    engine.dispose()
    with open_history(url) as h:
        with h.engine.connect() as conn:
            assert "circle_checks" in _tables(conn)
            assert migrations.current(conn) == migrations.HEAD
        h.record_circle_check(_doc(circled))
        assert len(h.circle_checks(ROBOT)) == 1


def test_a_circle_flagged_after_a_joint_zero_crash_is_an_alarm(circled):
    # Seed 3's arm with joint 2's zero turned 0.4 mrad (a knock), checked against the
    # calibration of the arm as it was.
    (circled / "crashed.yaml").write_text(
        "world: 1\nmodel: ur10e\nseed: 3\njoint_zero_shifts_rad: [0, 4.0e-4, 0, 0, 0, 0]\n"
    )
    done = cli(
        "check", "--circle", "--model", "ur10e", "--world", "crashed.yaml", "--calibration",
        "cal.json", "--circle-speed", "400", "-o", "crashed.json", "--history", "crash.db",
        cwd=circled,
    )  # fmt: skip
    assert done.code == 3, (done.stdout, done.stderr)
    assert "recorded circle check 1 in crash.db" in done.stdout
    circle = json.loads((circled / "crashed.json").read_text())
    robot = circle["robot"]
    done = cli("history", "alarms", robot, "--history", "crash.db", "--json", "-", cwd=circled)
    assert done.code == 0, done.stderr
    (alarm,) = json.loads(done.stdout)["alarms"]
    assert alarm["kind"] == "circle" and alarm["subject"] == "flagged"
    assert alarm["records"] == "circle check 1"
    roundness = circle["circle"]["out_of_roundness_mm"]
    assert f"out-of-roundness {roundness:.3f} mm beyond its limit 0.1 mm" in alarm["message"]
    assert alarm["figure"] == roundness and alarm["threshold"] == 0.1
    shown = cli("history", robot, "--history", "crash.db", cwd=circled)
    assert "ALARM" in shown.stdout and "circle: flagged" in shown.stdout


def test_the_record_reads_the_documents_fields():
    doc = {
        "format": "calibrator-check-circle",
        "robot": "arm-1",
        "time": "2026-03-01T08:00:00+01:00",
        "calibration_sha256": "ab" * 32,
        "verdict": "flagged",
        "circle": {
            "verdict": "flagged",
            "compensated": True,
            "commanded": {"radius_mm": 90.0},
            "speed_mm_s": 100.0,
            "radius_error_mm": -0.08,
            "out_of_roundness_mm": 0.3,
            "reversal_mm": 0.01,
            "centre_offset_norm_mm": 0.12,
            "direction_gap_mm": None,
        },
    }
    row = records.circle_check(doc).row
    assert row["time"].isoformat() == "2026-03-01T07:00:00"  # UTC
    assert row["radius_error_mm"] == -0.08 and row["direction_gap_mm"] is None
    assert row["verdict"] == "flagged" and row["radius_mm"] == 90.0


def _tables(conn):
    from sqlalchemy import inspect

    return set(inspect(conn).get_table_names())
