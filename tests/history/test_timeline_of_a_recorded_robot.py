"""A robot's timeline read from a real SQLite history: rows, their order at one time, trackers.

Found by mutation testing (issue 44): the timeline's rows were read only
through the command line's output.
"""

from __future__ import annotations

import csv
import io
import shutil

from history_kit import check_doc

from calibrator.history import open_history, timeline

ROBOT = "sim:er10l-c10:seed=3"


def test_a_session_comes_before_its_calibration_at_the_same_time(measured, tmp_path):
    for name in ("s0.parquet", "cal0.json", "verify.json"):
        shutil.copy(measured / name, tmp_path / name)
    with open_history(tmp_path / "h.sqlite") as h:
        cal_id = h.record_calibration(tmp_path / "cal0.json")
        test_id = h.record_verification(tmp_path / "verify.json")
        check_id = h.record_check(check_doc(robot=ROBOT, day=3000, verdict="drifted"))
        data = timeline.load(h, ROBOT)
    (session,) = data.sessions
    (calibration,) = data.calibrations
    assert calibration["time"] == session["measured_at"]  # filed under its session's time
    assert data.robot["name"] == ROBOT and data.robot["calibrations"] == 1
    assert [t["name"] for t in data.trackers] == ["CALIBRATOR:TRACKER-SIM:SIM-0001"]
    rows = timeline.table(data)
    assert [(r["record"], r["id"]) for r in rows][:2] == [
        ("session", session["id"]),
        ("calibration", cal_id),
    ]
    assert {(r["record"], r["id"]) for r in rows[2:]} == {
        ("iso9283 nominal", test_id),
        ("check", check_id),
    }
    assert rows[0]["file"] == session["file"] and rows[1]["file"] == calibration["file"]
    assert rows[1]["held_out_mm"] == calibration["held_out_rms_mm"]
    check = next(r for r in rows if r["record"] == "check")
    assert (check["verdict"], check["measured_mm"], check["file"]) == ("drifted", 0.05, None)
    read = list(csv.DictReader(io.StringIO(timeline.csv_text(rows))))
    assert [r["id"] for r in read][:2] == [str(session["id"]), str(cal_id)]
    assert read[0]["time"] == session["measured_at"].isoformat()
    text = timeline.format_table(rows).split("\n")
    assert len(text) == 1 + len(rows)
    assert text[1].split()[2:4] == ["session", str(session["id"])]
    assert text[2].split()[2:5] == ["calibration", str(cal_id), f"{rows[1]['held_out_mm']:.4f}"]
