"""The history's store on SQLite and on a real PostgreSQL: records, refusals, identical contents."""

import json
import os
import shutil
from datetime import date, datetime

import pytest
from history_kit import check_doc, dump

from calibrator.history import HistoryError, open_history
from calibrator.history import store as store_module


def test_records_read_back(history_url, measured):
    with open_history(history_url) as h:
        cal_id = h.record_calibration(measured / "cal0.json")
        ver_id = h.record_verification(measured / "verify.json")
        chk_id = h.record_check(check_doc(robot="sim:er10l-c10:seed=3"))
        robots = h.robots()
        assert [r["name"] for r in robots] == ["sim:er10l-c10:seed=3", "sim:er10l-c10:seed=3"][:1]
        assert robots[0]["model"] == "er10l-c10" and robots[0]["calibrations"] == 1
        (cal,) = h.calibrations("sim:er10l-c10:seed=3")
        doc = json.loads((measured / "cal0.json").read_text())
        assert cal["id"] == cal_id
        assert cal["parameters"] == doc["deltas"]
        assert cal["uncertainties"] == {
            k: v for k, v in doc["uncertainty"]["standard_errors"].items() if k in doc["deltas"]
        }
        assert cal["held_out_rms_mm"] == doc["stats"]["validation"]["after"]["position_mm"]["mean"]
        assert cal["provenance"]["seed"] == doc["seed"] and cal["provenance"]["method"] == "lm"
        assert cal["created"] == datetime.fromisoformat(doc["created"]).replace(tzinfo=None)
        # The calibration's session was recorded with it, and is its robot's.
        (session,) = h.sessions("sim:er10l-c10:seed=3")
        assert cal["session_id"] == session["id"] and session["poses"] == 32
        assert cal["session_file"] == str((measured / "s0.parquet").resolve())
        # verify's simulated robot is the simulated cell of seed 0... named by verify itself.
        vdoc = json.loads((measured / "verify.json").read_text())
        (test,) = h.verifications(vdoc["robot"])
        assert test["id"] == ver_id
        assert test["ap_mm"] == max(p["AP_mm"] for p in vdoc["poses"])
        assert test["document"] == vdoc
        (check,) = h.checks("sim:er10l-c10:seed=3")
        assert check["id"] == chk_id and check["time"] == datetime(2026, 1, 1)


def test_a_file_recorded_twice_is_one_record(history_url, measured):
    with open_history(history_url) as h:
        first = h.record_calibration(measured / "cal1.json")
        assert h.record_calibration(measured / "cal1.json") == first
        assert h.record_check(check_doc()) == h.record_check(check_doc())
        assert len(h.calibrations("sim:er10l-c10:seed=3")) == 1
        assert len(h.checks("arm-1")) == 1


def test_same_files_give_identical_histories_on_both_backends(tmp_path, new_pg, measured):
    dumps = []
    for target in (str(tmp_path / "h.sqlite"), new_pg()):
        with open_history(target) as h:
            for i in range(3):
                h.record_calibration(measured / f"cal{i}.json")
            h.record_verification(measured / "verify.json")
            h.record_check(check_doc(robot="sim:er10l-c10:seed=3", verdict="drifted", measured=0.3))
            h.describe_tracker("leica:AT960:123", certificate_date=date(2026, 3, 1))
            h.describe_robot("sim:er10l-c10:seed=3", serial="S-1", description="cell 4")
            dumps.append(dump(h))
    assert dumps[0] == dumps[1]
    assert len(dumps[0]["calibrations"]) == 3 and len(dumps[0]["sessions"]) == 3


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda d: d.pop("verdict"), "missing 'verdict'"),
        (lambda d: d.update(verdict="fine"), "'verdict' must be one of ok, drifted, recalibrate"),
        (lambda d: d.update(measured_mm=float("nan")), "'measured_mm' must be a finite number"),
        (lambda d: d.update(measured_mm="0.1"), "'measured_mm' must be a finite number"),
        (lambda d: d.update(time="yesterday"), "is not an ISO 8601 time"),
        (lambda d: d.update(calibration_sha256="abc"), "64 hex digits"),
        (lambda d: d.update(pose_errors_mm=[0.1, None]), "'pose_errors_mm' must be"),
        (lambda d: d.update(robot=" "), "'robot' must be"),
    ],
)
def test_bad_check_refused_in_one_line_and_nothing_written(tmp_path, change, message):
    doc = check_doc()
    change(doc)
    with open_history(tmp_path / "h.sqlite") as h:
        with pytest.raises(HistoryError, match=message) as info:
            h.record_check(doc)
        assert "\n" not in str(info.value)
        assert h.robots() == []


def test_bad_files_refused(history_url, measured, tmp_path):
    broken = tmp_path / "broken.json"
    broken.write_text('{"format": "calibrator.calibration", "version": 1}')
    with open_history(history_url) as h:
        with pytest.raises(HistoryError):
            h.record_calibration(broken)
        with pytest.raises(HistoryError, match="is not a calibrator verify file"):
            h.record_verification(measured / "cal0.json")
        # A calibration whose session is neither recorded nor beside it names no robot.
        alone = tmp_path / "alone" / "cal.json"
        alone.parent.mkdir()
        shutil.copy(measured / "cal2.json", alone)
        here = os.getcwd()
        os.chdir(tmp_path)
        try:
            with pytest.raises(HistoryError, match="give the robot"):
                h.record_calibration(alone)
        finally:
            os.chdir(here)
        assert h.robots() == []
        assert h.record_calibration(alone, robot="cell-4") > 0
        assert [r["name"] for r in h.robots()] == ["cell-4"]


def test_a_failure_inside_a_record_leaves_nothing(history_url, monkeypatch):
    """The robot is created inside the record's transaction: a failure after it undoes it."""
    real = store_module.History._insert_or_get
    calls = []

    def fail_on_the_check(conn, table, row, key):
        calls.append(table.name)
        if table.name == "checks":
            raise HistoryError("disk full (injected)")
        return real(conn, table, row, key)

    with open_history(history_url) as h:
        monkeypatch.setattr(store_module.History, "_insert_or_get", staticmethod(fail_on_the_check))
        with pytest.raises(HistoryError, match="injected"):
            h.record_check(check_doc(robot="new-arm"))
        monkeypatch.undo()
        assert calls == ["robots", "checks"]
        assert h.robots() == []


def test_unknown_robot_names_the_known_ones(history_url):
    with open_history(history_url) as h:
        h.record_check(check_doc(robot="arm-1"))
        with pytest.raises(HistoryError, match=r"no robot 'arm-2' .*\(arm-1\)"):
            h.calibrations("arm-2")


def test_opening_refuses_what_is_not_a_history(tmp_path):
    with pytest.raises(HistoryError, match="no history at"):
        open_history(tmp_path / "none.sqlite", create=False)
    with pytest.raises(HistoryError, match="does not exist"):
        open_history(tmp_path / "nowhere" / "h.sqlite")
    garbage = tmp_path / "garbage.sqlite"
    garbage.write_bytes(b"not a database at all" * 100)
    with pytest.raises(HistoryError, match="garbage.sqlite"):
        open_history(garbage)
    assert garbage.read_bytes() == b"not a database at all" * 100
    import sqlite3

    other = tmp_path / "other.sqlite"
    with sqlite3.connect(other) as conn:
        conn.execute("CREATE TABLE t (x)")
    with pytest.raises(HistoryError, match="not a calibrator history"):
        open_history(other)
    with pytest.raises(HistoryError, match="give an SQLite file or postgresql://"):
        open_history("nosuchdriver+x://y")
    # A server that does not answer (nothing listens on port 1 of this machine).
    with pytest.raises(HistoryError, match=r"history postgresql\+psycopg://nobody@127.0.0.1:1/h"):
        open_history("postgresql://nobody@127.0.0.1:1/h")


def test_default_location_and_environment(tmp_path, monkeypatch):
    monkeypatch.delenv(store_module.ENV_VAR, raising=False)
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "data"))
    with pytest.raises(HistoryError, match="no history at"):
        open_history(create=False)
    assert not (tmp_path / "data").exists()
    with open_history() as h:
        h.record_check(check_doc())
    assert (tmp_path / "data" / "calibrator" / "history.sqlite").is_file()
    monkeypatch.setenv(store_module.ENV_VAR, str(tmp_path / "team.sqlite"))
    with open_history() as h:
        assert h.robots() == []
    assert (tmp_path / "team.sqlite").is_file()


def test_a_session_is_dated_by_its_first_measured_pose():
    import pyarrow as pa

    from calibrator.history import records

    stamps = ["2026-03-02T10:00:05.000+01:00", "2026-03-02T09:59:59.500+01:00", "garbled"]
    table = pa.table({"timestamp": pa.array(stamps, pa.string())})
    assert records._first_time(table) == datetime(2026, 3, 2, 8, 59, 59, 500000)
    assert records._first_time(pa.table({"pose": [1]})) is None
