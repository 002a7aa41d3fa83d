"""Opening a history: nothing written to what it does not recognise, no hang on a silent server.

SQLite files are probed read-only before any connection that could write;
every exchange with a PostgreSQL server ends within the history's timeout,
whether the server never answers the connection, a statement waits on
another connection's lock, or the server process stops mid-statement.
"""

import os
import signal
import socket
import sqlite3
import threading
import time

import pytest
from cli_kit import cli, one_line_error
from cli_process_kit import run_cli

from calibrator.history import HistoryError, open_history

# -- SQLite: read-only probing ----------------------------------------------------------


def _foreign_database(path, journal="delete"):
    """An SQLite database of someone else's (one table), in its own journal mode."""
    conn = sqlite3.connect(path)
    conn.execute(f"PRAGMA journal_mode = {journal}")
    conn.execute("CREATE TABLE parts (id INTEGER PRIMARY KEY, name TEXT)")
    conn.execute("INSERT INTO parts (name) VALUES ('flange')")
    conn.commit()
    conn.close()
    return path.read_bytes()


@pytest.mark.parametrize(
    "command", [["history"], ["history", "robot", "r1"], ["history", "tracker", "t:m:s"]]
)
@pytest.mark.parametrize("journal", ["delete", "wal"])
def test_a_database_that_is_no_history_stays_byte_identical(tmp_path, command, journal):
    before = _foreign_database(tmp_path / "other.sqlite", journal)
    # Bytes 18-19: 1 1 for a rollback journal, 2 2 for a write-ahead log.
    assert before[18:20] == (b"\x01\x01" if journal == "delete" else b"\x02\x02")
    line = one_line_error(cli(*command, "--history", "other.sqlite", cwd=tmp_path))
    assert "other.sqlite is a database, but not a calibrator history" in line
    assert (tmp_path / "other.sqlite").read_bytes() == before  # no switch to WAL (bytes 18-19)
    # Nothing beside it either: no -wal, no -shm.
    assert sorted(p.name for p in tmp_path.iterdir()) == ["other.sqlite"]


def test_a_file_that_is_no_database_is_refused_untouched(tmp_path):
    (tmp_path / "notes.sqlite").write_bytes(b"these are my notes, not a database\n" * 200)
    line = one_line_error(cli("history", "robot", "r1", "--history", "notes.sqlite", cwd=tmp_path))
    assert "not an SQLite database" in line
    assert (tmp_path / "notes.sqlite").read_bytes() == b"these are my notes, not a database\n" * 200


def test_listing_a_history_on_an_existing_empty_file_writes_nothing(tmp_path):
    (tmp_path / "empty.sqlite").write_bytes(b"")
    line = one_line_error(cli("history", "--history", "empty.sqlite", cwd=tmp_path))
    assert "no history in empty.sqlite" in line
    assert (tmp_path / "empty.sqlite").read_bytes() == b""
    assert sorted(p.name for p in tmp_path.iterdir()) == ["empty.sqlite"]
    # Recording into it makes it a history (an empty file is a new one).
    done = cli("history", "robot", "r1", "--history", "empty.sqlite", cwd=tmp_path)
    assert done.code == 0, done.stderr
    assert "r1" in cli("history", "--history", "empty.sqlite", cwd=tmp_path).stdout


def test_mode_ro_is_honoured_reads_work_and_writes_are_refused_untouched(tmp_path):
    done = cli("history", "robot", "r1", "--history", "h.sqlite", cwd=tmp_path)
    assert done.code == 0, done.stderr
    before = (tmp_path / "h.sqlite").read_bytes()
    url = f"sqlite:///{tmp_path / 'h.sqlite'}?mode=ro"
    shown = run_cli("history", "--history", url, cwd=tmp_path, timeout=120)
    assert shown.returncode == 0, shown.stderr
    assert "r1" in shown.stdout and shown.stderr == ""  # no library warning
    refused = run_cli("history", "robot", "r2", "--history", url, cwd=tmp_path, timeout=120)
    assert refused.returncode == 2, refused.stderr
    assert len(refused.stderr.strip().splitlines()) == 1, refused.stderr
    assert "readonly" in refused.stderr or "read-only" in refused.stderr, refused.stderr
    assert (tmp_path / "h.sqlite").read_bytes() == before
    assert "r2" not in cli("history", "--history", "h.sqlite", cwd=tmp_path).stdout


@pytest.mark.parametrize(
    "query, message",
    [
        ("?cache=shared", "unknown option 'cache'"),
        ("?mode=memory", "mode=memory"),
        ("?timeout=abc", "'abc' is not a number of seconds"),
        ("?timeout=0", "'0' is not a number of seconds"),
    ],
)
def test_bad_history_url_options_are_refused_in_one_line(tmp_path, query, message):
    url = f"sqlite:///{tmp_path / 'h.sqlite'}{query}"
    assert message in one_line_error(cli("history", "robot", "r1", "--history", url, cwd=tmp_path))
    assert not (tmp_path / "h.sqlite").exists()


# -- PostgreSQL: timeouts on a real server -----------------------------------------------


def _with_timeout(url, seconds):
    return url + ("&" if "?" in url else "?") + f"timeout={seconds}"


def _robots(url):
    with open_history(url) as h:
        return [r["name"] for r in h.robots()]


def _locked(url):
    """A second connection holding an exclusive lock on the robots table (its transaction open)."""
    import psycopg

    conn = psycopg.connect(url)
    conn.execute("LOCK TABLE robots IN ACCESS EXCLUSIVE MODE")
    return conn


def test_a_statement_blocked_on_a_lock_ends_within_its_timeout_and_writes_nothing(new_pg):
    url = new_pg()
    with open_history(url) as h:
        h.describe_robot("r1")
    locker = _locked(url)
    try:
        start = time.monotonic()
        done = run_cli(
            "history", "robot", "r2", "--history", _with_timeout(url, 3), timeout=60
        )  # fmt: skip
        took = time.monotonic() - start
    finally:
        locker.rollback()
        locker.close()
    assert done.returncode == 2, done.stderr
    assert len(done.stderr.strip().splitlines()) == 1, done.stderr
    assert "no answer within 3 s" in done.stderr
    assert took < 3 + 15, took  # the timeout, and a process's start on a loaded machine
    assert _robots(url) == ["r1"]  # nothing half-written


def _waiting_backend(url, deadline):
    """The server process of the statement that waits on a lock (its pid)."""
    import psycopg

    with psycopg.connect(url, autocommit=True) as conn:
        while time.monotonic() < deadline:
            row = conn.execute(
                "SELECT pid FROM pg_stat_activity WHERE wait_event_type = 'Lock' "
                "AND datname = current_database()"
            ).fetchone()
            if row:
                return row[0]
            time.sleep(0.05)
    raise AssertionError("no statement came to wait on the lock")


def test_a_server_process_stopped_mid_statement_ends_the_command_within_its_timeout(new_pg):
    # The server's own statement timeout cannot fire in a stopped process: the
    # client's watchdog must end the exchange.
    from cli_process_kit import start_cli

    url = new_pg()
    with open_history(url) as h:
        h.describe_robot("r1")
    locker = _locked(url)
    stopped = None
    child = start_cli("history", "robot", "r2", "--history", _with_timeout(url, 4))
    try:
        stopped = _waiting_backend(url, time.monotonic() + 30)
        os.kill(stopped, signal.SIGSTOP)
        start = time.monotonic()
        out, err = child.communicate(timeout=60)
        took = time.monotonic() - start
    finally:
        if child.poll() is None:
            child.kill()
            child.communicate()
        if stopped is not None:
            os.kill(stopped, signal.SIGCONT)
        locker.rollback()
        locker.close()
    assert child.returncode == 2, err
    assert len(err.strip().splitlines()) == 1, err
    assert "no answer within 4 s" in err
    assert took < 4 + 10, took
    assert _robots(url) == ["r1"]  # the stopped transaction was never committed


class _SilentServer:
    """A TCP server on 127.0.0.1 that accepts every connection and never says a word."""

    def __init__(self):
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(16)
        self.port = self.sock.getsockname()[1]
        self.held = []
        self.thread = threading.Thread(target=self._accept, daemon=True)
        self.thread.start()

    def _accept(self):
        while True:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                return
            self.held.append(conn)

    def close(self):
        self.sock.close()
        for conn in self.held:
            conn.close()


@pytest.fixture
def silent():
    server = _SilentServer()
    yield f"postgresql://someone@127.0.0.1:{server.port}/history?timeout=2"
    server.close()


def test_a_server_that_accepts_and_never_answers_hangs_no_history_command(tmp_path, silent):
    for command in (["history"], ["history", "robot", "r1"]):
        start = time.monotonic()
        done = run_cli(*command, "--history", silent, cwd=tmp_path, timeout=60)
        assert time.monotonic() - start < 2 + 15
        assert done.returncode == 2, done.stderr
        assert len(done.stderr.strip().splitlines()) == 1, done.stderr
        assert "no answer within 2 s" in done.stderr, done.stderr


def test_identify_and_check_refuse_a_silent_history_before_their_work(measured, tmp_path, silent):
    start = time.monotonic()
    done = run_cli(
        "identify", measured / "s0.parquet", "-o", "cal.json", "--method", "lm",
        "--history", silent, cwd=tmp_path, timeout=60,
    )  # fmt: skip
    assert time.monotonic() - start < 2 + 15
    assert done.returncode == 2 and "no answer within 2 s" in done.stderr, done.stderr
    assert not (tmp_path / "cal.json").exists()  # refused before writing its calibration
    done = run_cli(
        "check", "--calibration", measured / "cal0.json", "-o", "check.json",
        "--history", silent, cwd=tmp_path, timeout=60,
    )  # fmt: skip
    assert done.returncode == 2 and "no answer within 2 s" in done.stderr, done.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_an_open_history_refuses_a_bad_timeout_from_the_environment(tmp_path, monkeypatch):
    monkeypatch.setenv("CALIBRATOR_HISTORY_TIMEOUT", "forever")
    with pytest.raises(HistoryError, match="CALIBRATOR_HISTORY_TIMEOUT: 'forever'"):
        open_history(tmp_path / "h.sqlite")
    assert not (tmp_path / "h.sqlite").exists()


def test_a_history_another_program_holds_locked_is_said_so_within_the_timeout(tmp_path):
    assert cli("history", "robot", "r1", "--history", "h.sqlite", cwd=tmp_path).code == 0
    holder = sqlite3.connect(tmp_path / "h.sqlite", isolation_level=None)
    holder.execute("PRAGMA locking_mode = EXCLUSIVE")
    holder.execute("BEGIN EXCLUSIVE")
    try:
        url = f"sqlite:///{tmp_path / 'h.sqlite'}?timeout=1"
        start = time.monotonic()
        line = one_line_error(cli("history", "--history", url, cwd=tmp_path))
        assert time.monotonic() - start < 1 + 10
    finally:
        holder.rollback()
        holder.close()
    assert "no answer within 1 s" in line, line


def test_listing_an_empty_postgresql_database_writes_no_schema_into_it(new_pg, tmp_path):
    import psycopg

    url = new_pg()
    line = one_line_error(cli("history", "--history", url, cwd=tmp_path))
    assert "no history in" in line and "an empty database" in line
    with psycopg.connect(url) as conn:
        tables = conn.execute(
            "SELECT count(*) FROM information_schema.tables WHERE table_schema = 'public'"
        ).fetchone()[0]
    assert tables == 0


def test_a_command_that_fails_after_the_history_check_leaves_no_new_history(measured, tmp_path):
    (tmp_path / "bad.parquet").write_bytes(b"not a session")
    done = cli(
        "identify", "bad.parquet", "-o", "c.json", "--history", "new.sqlite", cwd=tmp_path
    )  # fmt: skip
    assert done.code == 2, done.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.parquet"]
    done = cli(
        "identify", measured / "s0.parquet", "-o", "c.json", "--method", "lm",
        "--history", "new.sqlite", cwd=tmp_path,
    )  # fmt: skip
    assert done.code == 0, done.stderr
    assert "recorded calibration" in done.stdout and (tmp_path / "new.sqlite").is_file()
