"""The SQLite history store in-process: how long it waits, what it says, what it files where.

Real SQLite files, real second connections holding real locks (no process
started). Found by mutation testing (issue 44): the tests that reached these
cases ran as processes or on PostgreSQL, which the mutation runs leave out.
"""

from __future__ import annotations

import sqlite3
import threading
import time
from datetime import datetime

import pytest
from history_kit import check_doc

from calibrator.history import HistoryError, open_history, records, store


def test_the_url_timeout_wins_over_the_environment_and_that_over_the_default(tmp_path, monkeypatch):
    path = tmp_path / "h.sqlite"
    monkeypatch.delenv(store.TIMEOUT_ENV, raising=False)
    with open_history(path) as h:
        assert h.engine.history_timeout_s == store.DEFAULT_TIMEOUT_S
    monkeypatch.setenv(store.TIMEOUT_ENV, "5")
    with open_history(path) as h:
        assert h.engine.history_timeout_s == 5.0
    with open_history(f"sqlite:///{path}?timeout=2") as h:
        assert h.engine.history_timeout_s == 2.0
    monkeypatch.setenv(store.TIMEOUT_ENV, "0.1")
    with pytest.raises(HistoryError, match=r"CALIBRATOR_HISTORY_TIMEOUT: '0.1' is not a number"):
        open_history(path)


def test_a_writer_waits_for_another_writers_lock_then_says_so_in_one_line(tmp_path):
    path = tmp_path / "h.sqlite"
    with open_history(path) as h:
        h.record_check(check_doc(day=0))
    with open_history(f"sqlite:///{path}?timeout=0.5") as h:
        holder = sqlite3.connect(path, isolation_level=None)
        holder.execute("BEGIN IMMEDIATE")
        try:
            start = time.monotonic()
            with pytest.raises(HistoryError) as caught:
                h.record_check(check_doc(day=1))
            waited = time.monotonic() - start
        finally:
            holder.rollback()
            holder.close()
    assert 0.4 < waited < 0.5 + 10
    assert str(caught.value) == (
        f"history {path}: no answer within 0.5 s; nothing was written (a history URL's "
        "?timeout=SECONDS or $CALIBRATOR_HISTORY_TIMEOUT sets the limit)"
    )
    with open_history(path) as h:
        assert len(h.checks("arm-1")) == 1


def test_a_writer_that_finds_the_lock_released_in_time_records(tmp_path):
    path = tmp_path / "h.sqlite"
    with open_history(path) as h:
        h.record_check(check_doc(day=0))
    with open_history(f"sqlite:///{path}?timeout=20") as h:
        holder = sqlite3.connect(path, isolation_level=None, check_same_thread=False)
        holder.execute("BEGIN IMMEDIATE")
        release = threading.Timer(0.3, holder.rollback)
        release.start()
        try:
            h.record_check(check_doc(day=1))
            assert len(h.checks("arm-1")) == 2
        finally:
            release.join(timeout=30)
            holder.close()


def test_opening_waits_for_a_lock_that_blocks_the_switch_to_the_write_ahead_log(tmp_path):
    """A history in rollback-journal mode (as an older copy may be) whose switch to the
    write-ahead log meets another connection's lock: SQLite refuses at once, the store
    retries until the lock goes."""
    path = tmp_path / "h.sqlite"
    with open_history(path) as h:
        h.record_check(check_doc(day=0))
    conn = sqlite3.connect(path)
    assert conn.execute("PRAGMA journal_mode = DELETE").fetchone() == ("delete",)
    conn.close()
    holder = sqlite3.connect(path, isolation_level=None, check_same_thread=False)
    # A writer's reserved lock: the switch, which needs the file to itself, is
    # refused at once (SQLite calls no busy handler where waiting could deadlock).
    holder.execute("BEGIN IMMEDIATE")
    release = threading.Timer(0.4, holder.rollback)
    release.start()
    try:
        start = time.monotonic()
        with open_history(f"sqlite:///{path}?timeout=20") as h:
            assert len(h.checks("arm-1")) == 1
        assert time.monotonic() - start >= 0.3
    finally:
        release.join(timeout=30)
        holder.close()
    with sqlite3.connect(path) as conn:
        assert conn.execute("PRAGMA journal_mode").fetchone() == ("wal",)


def test_the_timeouts_the_drivers_report_are_recognised():
    for text in (
        "timeout expired",
        "canceling statement due to statement timeout",
        "canceling statement due to lock timeout",
        "database is locked",
    ):
        assert store._timed_out(Exception(text.upper()))
    assert not store._timed_out(Exception("no such table: checks"))

    class Wrapped(Exception):
        orig = sqlite3.OperationalError("database is locked")

    assert store._timed_out(Wrapped("(sqlite3.OperationalError) ... [SQL: BEGIN]"))


def test_a_read_only_history_refuses_a_record_with_the_drivers_words_only(tmp_path):
    path = tmp_path / "h.sqlite"
    with open_history(path) as h:
        h.record_check(check_doc(day=0))
    with open_history(f"sqlite:///{path}?mode=ro") as h:
        assert len(h.checks("arm-1")) == 1
        with pytest.raises(HistoryError) as caught:
            h.record_check(check_doc(day=1))
    assert str(caught.value) == f"history {path}: attempt to write a readonly database"


def test_robots_and_trackers_described_keep_what_is_given(tmp_path):
    from datetime import date

    with open_history(tmp_path / "h.sqlite") as h:
        first = h.describe_robot(" arm-1 ", model="ur10e", serial="20235500", description="cell 3")
        assert h.describe_robot("arm-1", description="cell 4") == first
        h.describe_tracker("leica:AT960:7", model="AT960", serial="7")
        h.describe_tracker("leica:AT960:7", certificate_date=date(2026, 2, 1))
        h.record_check(check_doc(robot="arm-1"))
        assert h.robots() == [
            {"name": "arm-1", "model": "ur10e", "serial": "20235500", "description": "cell 4",
             "calibrations": 0}
        ]  # fmt: skip
        assert h.trackers() == [
            {"name": "leica:AT960:7", "model": "AT960", "serial": "7",
             "certificate_date": date(2026, 2, 1)}
        ]  # fmt: skip
        with pytest.raises(HistoryError, match="a robot or tracker needs a name"):
            h.describe_robot("  ")


def _session_with_footer(measured, tmp_path):
    from dataclasses import replace

    from calibrator import session as sessions

    loaded = sessions.load(measured / "s0.parquet")
    extra = {
        **loaded.meta.extra,
        "tool_id": "smr-1.5in",
        "measured_at": "2026-04-01T06:30:00Z",
        "measured": {"robot": "cell-3 arm", "tracker": "leica:AT960:7"},
    }
    path = tmp_path / "s0.parquet"
    sessions.write(path, loaded.table, replace(loaded.meta, extra=extra))
    return path


def test_a_calibration_is_filed_under_its_sessions_time_robot_and_set_up(measured, tmp_path):
    import shutil

    _session_with_footer(measured, tmp_path)
    # The calibration of the original s0.parquet names another digest: identify this one.
    from cli_kit import cli

    done = cli("identify", "s0.parquet", "-o", "cal.json", "--method", "lm", "-q", cwd=tmp_path)
    assert done.code == 0, done.stderr
    shutil.copy(measured / "cal1.json", tmp_path / "other.json")
    with open_history(tmp_path / "h.sqlite") as h:
        h.record_calibration(tmp_path / "cal.json")  # its session recorded with it
        (row,) = h.calibrations("cell-3 arm")
        (session,) = h.sessions("cell-3 arm")
        assert session["tracker"] == "leica:AT960:7"
        # Recorded again: the same row.
        assert h.record_calibration(tmp_path / "cal.json") == row["id"]
    assert row["measured_at"] == row["time"] == datetime(2026, 4, 1, 6, 30)
    assert row["session_id"] == session["id"]
    assert row["session_file"] == str((tmp_path / "s0.parquet").resolve())
    assert row["file"] == str((tmp_path / "cal.json").resolve())
    assert row["statistics"]["setup"] == {"tool_id": "smr-1.5in"}
    assert row["statistics"]["arm"]["names"]  # what the alarms compare


def test_a_calibration_whose_session_is_unknown_needs_a_robot(measured, tmp_path):
    import shutil

    shutil.copy(measured / "cal2.json", tmp_path / "cal2.json")  # no s2.parquet beside it
    with open_history(tmp_path / "h.sqlite") as h:
        with pytest.raises(HistoryError, match="its session is not in the history and names no"):
            h.record_calibration(tmp_path / "cal2.json")
        h.record_calibration(tmp_path / "cal2.json", robot="arm-9")
        (row,) = h.calibrations("arm-9")
    assert row["session_id"] is None and row["measured_at"] is None
    assert row["time"] == row["created"]
    assert row["statistics"]["setup"] == {}


def test_records_of_a_robot_are_read_in_time_order_whatever_the_order_recorded(tmp_path):
    with open_history(tmp_path / "h.sqlite") as h:
        for day in (5, 1, 3):
            h.record_check(check_doc(day=day))
        times = [c["time"] for c in h.checks("arm-1")]
    assert times == sorted(times) and len(times) == 3
    assert records.utc(check_doc(day=1)["time"], "t") == times[0]


def test_a_damaged_history_is_refused_with_the_drivers_words_in_one_line(tmp_path):
    """A history someone removed a table from: the driver's error, without its SQL."""
    path = tmp_path / "h.sqlite"
    with open_history(path) as h:
        h.record_check(check_doc(day=0))
    with sqlite3.connect(path) as conn:
        conn.execute("DROP TABLE checks")
    with open_history(path) as h, pytest.raises(HistoryError) as caught:
        h.record_check(check_doc(day=1))
    assert str(caught.value) == f"history {path}: no such table: checks"


def test_calibrations_of_one_session_are_listed_in_the_order_recorded(measured, tmp_path):
    """Two calibrations of one session share its time: the one recorded first comes first,
    whichever was made earlier (here the second was made a day before the first)."""
    import json
    import shutil

    shutil.copy(measured / "s0.parquet", tmp_path / "s0.parquet")
    doc = json.loads((measured / "cal0.json").read_text())
    made = (("late.json", "2026-05-02T00:00:00Z"), ("early.json", "2026-05-01T00:00:00Z"))
    for name, created in made:
        (tmp_path / name).write_text(json.dumps(doc | {"created": created}))
    with open_history(tmp_path / "h.sqlite") as h:
        first = h.record_calibration(tmp_path / "late.json")
        second = h.record_calibration(tmp_path / "early.json")
        rows = h.calibrations("sim:er10l-c10:seed=3")
    assert [r["id"] for r in rows] == [first, second]
    assert rows[0]["time"] == rows[1]["time"]
