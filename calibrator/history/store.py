"""The history database: open (and upgrade) it, record into it, read it back.

Every record is one transaction: the robot and tracker it names are
created if new, its row is inserted, and all of it lands or none does. A
file recorded twice is one record (its SHA-256 is unique), so two processes
recording the same or different files at once lose nothing and duplicate
nothing. On SQLite a writer takes the file's write lock when its transaction
begins (``BEGIN IMMEDIATE``) and others wait for it; on PostgreSQL rows are
inserted with ``ON CONFLICT DO NOTHING`` and the schema upgrade holds an
advisory lock.
"""

from __future__ import annotations

import os
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import replace
from datetime import date
from pathlib import Path
from typing import Any

from calibrator.history import migrations, records, schema
from calibrator.history.records import HistoryError, Record

#: Environment variable naming the history when ``--history`` is not given.
ENV_VAR = "CALIBRATOR_HISTORY"
#: The longest any exchange with a history may take, s: connecting, one
#: transaction (its statements), a wait for another writer's lock. A server
#: that accepts a connection and never answers, or stops answering in the
#: middle of a statement, ends the command with one line after it.
DEFAULT_TIMEOUT_S = 30.0
#: Environment variable overriding :data:`DEFAULT_TIMEOUT_S`; a history URL's
#: ``?timeout=S`` wins over both (docs/history.md).
TIMEOUT_ENV = "CALIBRATOR_HISTORY_TIMEOUT"
#: How long a writer waits for another's lock on an SQLite file (s), by default.
SQLITE_WAIT_S = DEFAULT_TIMEOUT_S
#: Query options of an SQLite history URL this module reads (any other is refused).
_SQLITE_OPTIONS = ("mode", "timeout")
#: Key of the PostgreSQL advisory lock that serialises schema upgrades.
_UPGRADE_LOCK = 0x63616C69


def default_path() -> Path:
    """The history file used when none is named: ``$XDG_DATA_HOME/calibrator/history.sqlite``.

    ``XDG_DATA_HOME`` defaults to ``~/.local/share``.
    """
    base = os.environ.get("XDG_DATA_HOME") or str(Path.home() / ".local" / "share")
    return Path(base) / "calibrator" / "history.sqlite"


def resolve(target: str | os.PathLike | None, create: bool = True) -> str:
    """The database URL of ``--history`` (a file or a URL), ``$CALIBRATOR_HISTORY`` or the default.

    A file path becomes ``sqlite:///PATH``; ``postgresql://`` gets the
    psycopg driver. With ``create``, the default file's folder is made.
    """
    if target is None or str(target) == "":
        target = os.environ.get(ENV_VAR) or None
    if target is None:
        path = default_path()
        if create:  # a look at a history that is not there makes no folder
            path.parent.mkdir(parents=True, exist_ok=True)
        return f"sqlite:///{path}"
    text = str(target)
    if text.startswith(("postgresql://", "postgres://")):
        return "postgresql+psycopg://" + text.split("://", 1)[1]
    if "://" in text:
        return text
    return f"sqlite:///{Path(text).expanduser()}"


def _timeout(parsed: Any) -> float:
    """The timeout, s: the URL's ``timeout``, else :data:`TIMEOUT_ENV`, else the default."""
    given = parsed.query.get("timeout")
    source = "timeout in the history URL"
    if given is None:
        given, source = os.environ.get(TIMEOUT_ENV), TIMEOUT_ENV
    if given is None:
        return DEFAULT_TIMEOUT_S
    try:
        value = float(given if isinstance(given, str) else given[-1])
    except ValueError:
        value = float("nan")
    if not 0.5 <= value <= 3600.0:  # also refuses nan
        raise HistoryError(f"{source}: {given!r} is not a number of seconds in [0.5, 3600]")
    return value


def _engine(url: str, create: bool) -> Any:
    from sqlalchemy.engine import make_url
    from sqlalchemy.exc import ArgumentError

    try:
        parsed = make_url(url)
    except ArgumentError:
        raise HistoryError(
            f"--history {url}: not a file or a database URL "
            "(give an SQLite file or postgresql://USER@HOST/DB)"
        ) from None
    timeout = _timeout(parsed)
    parsed = parsed.difference_update_query(["timeout"])
    if parsed.get_backend_name() == "sqlite":
        return _sqlite_engine(parsed, create, timeout)
    return _server_engine(parsed, timeout)


def _sqlite_engine(parsed: Any, create: bool, timeout: float) -> Any:
    """An SQLite history, probed read-only first: nothing is written to a file it does not know.

    A file that holds tables but no calibrator history, or that is no SQLite
    database at all, is refused before any connection that could write (the
    switch to the write-ahead log changes a file's header). An existing empty
    file is a history only for a command that records (``create``): a look at
    it writes nothing. ``?mode=ro`` opens the file read-only.
    """
    from sqlalchemy import create_engine, event

    unknown = sorted(set(parsed.query) - set(_SQLITE_OPTIONS))
    if unknown:
        raise HistoryError(
            f"--history: unknown option {unknown[0]!r} for an SQLite history "
            "(known: mode=ro, timeout=SECONDS)"
        )
    mode = parsed.query.get("mode")
    if mode not in (None, "ro", "rw", "rwc"):
        raise HistoryError(f"--history: mode={mode} (an SQLite history takes mode=ro, rw or rwc)")
    read_only = mode == "ro"
    path = Path(parsed.database or "")
    if not parsed.database or parsed.database == ":memory:":
        raise HistoryError("--history: give a file for SQLite (a history in memory is lost)")
    if not path.exists():
        if not create or read_only or mode == "rw":
            raise HistoryError(f"no history at {path}")
        if not path.parent.is_dir():
            raise HistoryError(f"--history {path}: folder {path.parent} does not exist")
    elif not path.is_file():
        raise HistoryError(f"--history {path}: not a file")
    else:
        revision = _probe_sqlite(path, timeout)
        if revision is None and not (create and not read_only):
            raise HistoryError(f"no history in {path} (an empty database: nothing recorded yet)")
        if read_only and revision != migrations.HEAD:
            raise HistoryError(
                f"{path} is at schema revision {revision}, older than this calibrator's "
                f"({migrations.HEAD}): open it once without mode=ro to upgrade it"
            )
    if read_only:
        import sqlite3
        from urllib.parse import quote

        uri = f"file:{quote(str(path.resolve()))}?mode=ro"
        engine = create_engine(
            "sqlite://", creator=lambda: sqlite3.connect(uri, uri=True, timeout=timeout)
        )
    else:
        engine = create_engine(parsed.set(query={}), connect_args={"timeout": timeout})

    @event.listens_for(engine, "connect")
    def _connect(dbapi_connection: Any, _record: Any) -> None:
        # pysqlite's own BEGIN comes late and deferred; ours comes first and
        # takes the write lock, so two writers queue instead of deadlocking.
        dbapi_connection.isolation_level = None
        dbapi_connection.execute("PRAGMA foreign_keys = ON")
        if not read_only:
            # A commit appends to the write-ahead log and syncs it once, where the
            # rollback journal syncs the journal and the file: a record took 29 ms
            # with the journal and 10 ms with the log (300 records,
            # benchmarks/history_records.py). Readers no longer wait for a writer.
            # Only here, after the probe: the mode is written into the file.
            _write_ahead_log(dbapi_connection, timeout)

    @event.listens_for(engine, "begin")
    def _begin(connection: Any) -> None:
        # A read-only file takes no write lock: a deferred transaction only reads.
        connection.exec_driver_sql("BEGIN" if read_only else "BEGIN IMMEDIATE")

    engine.history_timeout_s = timeout  # type: ignore[attr-defined]
    # How messages name it: a read-only engine's URL holds no file (its creator opens it).
    engine.history_where = str(path)  # type: ignore[attr-defined]
    return engine


def _probe_sqlite(path: Path, timeout: float) -> str | None:
    """The revision of the history in ``path``, read without writing a byte.

    Returns
    -------
    str or None
        The revision; None for an empty database (a new, empty file).

    Raises
    ------
    HistoryError
        Not an SQLite database, a database that is not a calibrator history,
        or one at a revision newer than this calibrator reads.
    """
    import sqlite3
    from urllib.parse import quote

    if path.stat().st_size == 0:
        return None
    uri = f"file:{quote(str(path.resolve()))}?mode=ro"
    if not Path(f"{path}-wal").exists():
        # Nothing beside it: the file holds everything, and opening it immutable
        # takes no lock and leaves no -wal or -shm beside someone else's database.
        uri += "&immutable=1"
    try:
        conn = sqlite3.connect(uri, uri=True, timeout=timeout)
    except sqlite3.Error as exc:
        raise HistoryError(f"--history {path}: cannot open it ({exc})") from None
    try:
        tables = {n for (n,) in conn.execute("SELECT name FROM sqlite_master WHERE type='table'")}
        revision = None
        if "alembic_version" in tables:
            row = conn.execute("SELECT version_num FROM alembic_version").fetchone()
            revision = None if row is None else str(row[0])
    except sqlite3.DatabaseError as exc:
        if "locked" in str(exc) or "busy" in str(exc):
            raise HistoryError(
                f"history {path}: no answer within {timeout:g} s (another program holds its "
                f"lock; a history URL's ?timeout=SECONDS or ${TIMEOUT_ENV} sets the limit)"
            ) from None
        raise HistoryError(f"--history {path}: not an SQLite database ({exc})") from None
    finally:
        conn.close()
    if revision is None and tables:
        raise HistoryError(f"{path} is a database, but not a calibrator history")
    if revision is not None and revision not in migrations.REVISIONS:
        raise HistoryError(
            f"{path} is at schema revision {revision}, newer than this calibrator "
            f"reads ({migrations.HEAD}): upgrade calibrator"
        )
    return revision


def _server_engine(parsed: Any, timeout: float) -> Any:
    """A PostgreSQL history whose every exchange ends within ``timeout`` seconds.

    Three bounds, for three ways a server can fail to answer: ``connect_timeout``
    (a server that accepts the connection and never answers), the server's
    own ``statement_timeout`` and ``lock_timeout`` (a statement waiting on
    another connection's lock), and :class:`_Watchdog` on the client (a
    server that stops answering in the middle of a statement, where no
    timer of its own runs).
    """
    from sqlalchemy import create_engine, event

    ms = int(timeout * 1000)
    try:
        engine = create_engine(
            parsed,
            pool_pre_ping=True,
            connect_args={
                "connect_timeout": max(2, int(timeout + 0.5)),  # libpq's least is 2 s
                "options": f"-c statement_timeout={ms} -c lock_timeout={ms}",
            },
        )
    except Exception as exc:  # a driver missing or an option it refuses
        raise HistoryError(
            f"--history {parsed.render_as_string()}: {_one_line(exc)} "
            "(give an SQLite file or postgresql://USER@HOST/DB)"
        ) from None
    watchdog = _Watchdog(timeout)

    @event.listens_for(engine, "connect")
    def _connect(dbapi_connection: Any, _record: Any) -> None:
        watchdog.watch(dbapi_connection)

    engine.history_timeout_s = timeout  # type: ignore[attr-defined]
    engine.history_watchdog = watchdog  # type: ignore[attr-defined]
    return engine


class _Watchdog:
    """Ends an exchange with a server that stopped answering: shuts its sockets at a deadline.

    A statement the server never finishes (its process stopped, the network
    gone quiet while the kernel still acknowledges) blocks the client in a
    read no timer of the server's can end. :meth:`running` arms a timer for
    one transaction; when it fires, the sockets of the connections opened
    through this engine are shut, the blocked read returns, and the driver
    raises an error the caller reports in one line. The transaction was
    never committed, so the server rolls it back: nothing is half-written.
    """

    def __init__(self, seconds: float) -> None:
        import weakref

        self.seconds = seconds
        self.fired = False
        self._live: Any = weakref.WeakSet()

    def watch(self, dbapi_connection: Any) -> None:
        """Shut this connection too when the deadline passes."""
        self._live.add(dbapi_connection)

    @contextmanager
    def running(self) -> Iterator[None]:
        """The deadline armed for the block (one transaction)."""
        import threading

        self.fired = False
        timer = threading.Timer(self.seconds, self._fire)
        timer.daemon = True
        timer.start()
        try:
            yield
        finally:
            timer.cancel()

    def _fire(self) -> None:
        import socket

        self.fired = True
        for conn in list(self._live):
            try:
                fd = conn.pgconn.socket
                sock = socket.socket(fileno=os.dup(fd))
            except Exception:  # already closed: nothing to end
                continue
            try:
                sock.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass
            finally:
                sock.close()


def _write_ahead_log(dbapi_connection: Any, wait_s: float = SQLITE_WAIT_S) -> None:
    """Put an SQLite file in write-ahead-log mode, waiting up to ``wait_s`` for it.

    The mode is kept in the file, so only its first connections change it.
    SQLite answers a change of journal mode that meets another connection's
    lock with "database is locked" at once, without the busy timeout every
    other statement waits for: two processes opening a new history together
    lost one of them that way (1 run in 5). So the change is retried here.
    """
    import sqlite3

    deadline = time.monotonic() + wait_s
    pause = 0.001
    while True:
        try:
            (mode,) = dbapi_connection.execute("PRAGMA journal_mode").fetchone()
            if str(mode).lower() == "wal":
                return
            dbapi_connection.execute("PRAGMA journal_mode = WAL")
            return
        except sqlite3.OperationalError as exc:
            if "locked" not in str(exc) and "busy" not in str(exc):
                raise
            if time.monotonic() + pause > deadline:
                raise
        time.sleep(pause)
        pause = min(2 * pause, 0.05)


def _timed_out(exc: BaseException) -> bool:
    """The driver's error says a timeout ended the exchange (connecting, a statement, a lock)."""
    text = str(getattr(exc, "orig", None) or exc).lower()
    return any(
        words in text
        for words in (
            "timeout expired",  # connecting (psycopg)
            "statement timeout",  # the server's statement_timeout
            "lock timeout",  # the server's lock_timeout
            "database is locked",  # SQLite's busy timeout: another writer held the lock
        )
    )


def _one_line(exc: BaseException) -> str:
    text = str(getattr(exc, "orig", None) or exc)
    return " ".join(text.split())[:300]


class History:
    """A history database, upgraded to the newest schema. Use :func:`open_history`.

    Parameters
    ----------
    engine : sqlalchemy.engine.Engine
    where : str
        How to name it in messages (a path or the URL without password).
    """

    def __init__(self, engine: Any, where: str) -> None:
        self.engine = engine
        self.where = where

    # -- opening ---------------------------------------------------------------

    def upgrade(self, create: bool = True, change: bool = True) -> str | None:
        """Bring the schema to :data:`migrations.HEAD`; return the revision it was at.

        With ``create`` False an empty database is refused, not given the
        schema: a look at a history writes nothing into what holds none.
        With ``change`` False nothing is migrated: only what would be refused is.
        """
        from sqlalchemy import inspect

        with self._begin() as conn:
            if conn.dialect.name == "postgresql":
                conn.exec_driver_sql(f"SELECT pg_advisory_xact_lock({_UPGRADE_LOCK})")
            was = migrations.current(conn)
            if was is None and inspect(conn).get_table_names():
                raise HistoryError(f"{self.where} is a database, but not a calibrator history")
            if was is None and not create:
                raise HistoryError(
                    f"no history in {self.where} (an empty database: nothing recorded yet)"
                )
            if was is not None and was not in migrations.REVISIONS:
                raise HistoryError(
                    f"{self.where} is at schema revision {was}, newer than this calibrator "
                    f"reads ({migrations.HEAD}): upgrade calibrator"
                )
            if was != migrations.HEAD and change:
                migrations.upgrade(conn)
        return was

    def close(self) -> None:
        """Close every connection."""
        self.engine.dispose()

    def __enter__(self) -> History:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @contextmanager
    def _begin(self) -> Iterator[Any]:
        from contextlib import nullcontext

        from sqlalchemy.exc import DBAPIError, StatementError

        watchdog = getattr(self.engine, "history_watchdog", None)
        try:
            with watchdog.running() if watchdog else nullcontext(), self.engine.begin() as conn:
                yield conn
        except HistoryError:
            raise
        except (DBAPIError, StatementError) as exc:
            timeout = getattr(self.engine, "history_timeout_s", DEFAULT_TIMEOUT_S)
            if (watchdog is not None and watchdog.fired) or _timed_out(exc):
                raise HistoryError(
                    f"history {self.where}: no answer within {timeout:g} s; nothing was "
                    f"written (a history URL's ?timeout=SECONDS or ${TIMEOUT_ENV} sets the limit)"
                ) from None
            raise HistoryError(f"history {self.where}: {_one_line(exc)}") from None

    # -- recording -------------------------------------------------------------

    def record_session(self, path: str | os.PathLike, robot: str | None = None) -> int:
        """Record a session file (Parquet); return its id (the existing one if recorded).

        Raises
        ------
        HistoryError
            The file is not a session, or names no robot and none is given.
        """
        record = records.session(Path(path))
        with self._begin() as conn:
            return self._session(conn, record, robot, path)

    def record_calibration(self, path: str | os.PathLike, robot: str | None = None) -> int:
        """Record a calibration.json; return its id (the existing one if recorded).

        Its robot is ``robot`` if given, else its session's: the one the
        history holds with the calibration's session digest, else the
        session file it names (recorded with it, in the same transaction).
        """
        record = records.calibration(Path(path))
        record = replace(record, row={**record.row, "file": str(Path(path).resolve())})
        session_file = _session_file(record.session, Path(path))
        with self._begin() as conn:
            session_id, session_robot = self._session_of(conn, record.row["session_sha256"])
            if session_id is None and session_file is not None:
                found = records.session(session_file)
                if found.row["sha256"] == record.row["session_sha256"]:
                    session_id = self._session(conn, found, robot, session_file)
                    session_robot = self._robot_name(conn, session_id)
            name = robot or session_robot
            if name is None:
                raise HistoryError(
                    f"{path}: its session is not in the history and names no robot: "
                    "give the robot (--robot)"
                )
            measured_at, setup = self._session_facts(conn, session_id)
            row = {
                **record.row,
                "session_id": session_id,
                "measured_at": measured_at,
                # The set-up decides what the alarms may compare (history.compare).
                "statistics": {**record.row["statistics"], "setup": setup},
            }
            return self._insert(conn, schema.calibrations, replace(record, row=row), name)

    def record_verification(self, path: str | os.PathLike, robot: str | None = None) -> int:
        """Record verify's JSON (ISO 9283 pose test, or path test: its own table); its id."""
        record = records.verification(Path(path))
        record = replace(record, row={**record.row, "file": str(Path(path).resolve())})
        table = (
            schema.path_verifications if records.is_path_record(record) else schema.verifications
        )
        with self._begin() as conn:
            return self._insert(conn, table, record, robot or record.robot, path)

    def record_check(self, doc: dict) -> int:
        """Record a ``calibrator check`` document (:data:`records.CHECK_FIELDS`); return its id."""
        record = records.check(doc)
        with self._begin() as conn:
            return self._insert(conn, schema.checks, record, record.robot)

    def record_circle_check(self, doc: dict) -> int:
        """Record a ``calibrator check --circle`` document (:func:`records.circle_check`);
        return its id (the existing one if recorded)."""
        record = records.circle_check(doc)
        with self._begin() as conn:
            return self._insert(conn, schema.circle_checks, record, record.robot)

    def describe_robot(
        self,
        name: str,
        model: str | None = None,
        serial: str | None = None,
        description: str | None = None,
    ) -> int:
        """Create a robot or set what is given of its model, serial and description."""
        values = {"model": model, "serial": serial, "description": description}
        return self._describe(schema.robots, name, values)

    def describe_tracker(
        self,
        name: str,
        model: str | None = None,
        serial: str | None = None,
        certificate_date: date | None = None,
    ) -> int:
        """Create a tracker or set what is given of its model, serial and certificate date."""
        values = {"model": model, "serial": serial, "certificate_date": certificate_date}
        return self._describe(schema.trackers, name, values)

    def _describe(self, table: Any, name: str, values: dict) -> int:
        from sqlalchemy import update

        if not name.strip():
            raise HistoryError("a robot or tracker needs a name")
        given = {k: v for k, v in values.items() if v is not None}
        with self._begin() as conn:
            row_id = self._ensure(conn, table, name.strip(), {})
            if given:
                conn.execute(update(table).where(table.c.id == row_id).values(**given))
            return row_id

    def _session(self, conn: Any, record: Record, robot: str | None, path: Any) -> int:
        return self._insert(conn, schema.sessions, record, robot or record.robot, path)

    def _insert(
        self, conn: Any, table: Any, record: Record, robot: str | None, path: Any = None
    ) -> int:
        if not robot:
            raise HistoryError(f"{path or 'record'}: names no robot: give the robot (--robot)")
        row = dict(record.row)
        row["robot_id"] = self._ensure(conn, schema.robots, robot, {"model": record.model})
        if "tracker_id" in table.c:
            row["tracker_id"] = (
                self._ensure(conn, schema.trackers, record.tracker, _tracker_parts(record.tracker))
                if record.tracker
                else None
            )
        return self._insert_or_get(conn, table, row, "sha256")

    def _ensure(self, conn: Any, table: Any, name: str, values: dict) -> int:
        return self._insert_or_get(conn, table, {"name": name, **values}, "name")

    @staticmethod
    def _insert_or_get(conn: Any, table: Any, row: dict, key: str) -> int:
        from sqlalchemy import select
        from sqlalchemy.dialects import postgresql, sqlite

        dialect = postgresql if conn.dialect.name == "postgresql" else sqlite
        conn.execute(
            dialect.insert(table).values(**row).on_conflict_do_nothing(index_elements=[key])
        )
        return int(conn.execute(select(table.c.id).where(table.c[key] == row[key])).scalar_one())

    def _session_of(self, conn: Any, digest: str | None) -> tuple[int | None, str | None]:
        from sqlalchemy import select

        if not digest:
            return None, None
        s, r = schema.sessions, schema.robots
        found = conn.execute(
            select(s.c.id, r.c.name).join(r, r.c.id == s.c.robot_id).where(s.c.sha256 == digest)
        ).first()
        return (None, None) if found is None else (int(found[0]), str(found[1]))

    @staticmethod
    def _session_facts(conn: Any, session_id: int | None) -> tuple[Any, dict]:
        """When a calibration's session was measured and its set-up (None, {}: unknown)."""
        from sqlalchemy import select

        if session_id is None:
            return None, {}
        s = schema.sessions
        found = conn.execute(select(s.c.measured_at, s.c.setup).where(s.c.id == session_id)).one()
        return found[0], found[1] or {}

    @staticmethod
    def _robot_name(conn: Any, session_id: int) -> str:
        from sqlalchemy import select

        s, r = schema.sessions, schema.robots
        return str(
            conn.execute(
                select(r.c.name).join(s, s.c.robot_id == r.c.id).where(s.c.id == session_id)
            ).scalar_one()
        )

    # -- reading ---------------------------------------------------------------

    def robots(self) -> list[dict]:
        """Every robot: ``{"name", "model", "serial", "description", "calibrations"}``."""
        from sqlalchemy import func, select

        r, c = schema.robots, schema.calibrations
        count = select(func.count(c.c.id)).where(c.c.robot_id == r.c.id).scalar_subquery()
        query = select(
            r.c.name, r.c.model, r.c.serial, r.c.description, count.label("calibrations")
        )
        with self._begin() as conn:
            return [dict(row._mapping) for row in conn.execute(query.order_by(r.c.name))]

    def trackers(self) -> list[dict]:
        """Every tracker: ``{"name", "model", "serial", "certificate_date"}``."""
        from sqlalchemy import select

        t = schema.trackers
        query = select(t.c.name, t.c.model, t.c.serial, t.c.certificate_date).order_by(t.c.name)
        with self._begin() as conn:
            return [dict(row._mapping) for row in conn.execute(query)]

    def calibrations(self, robot: str) -> list[dict]:
        """A robot's calibrations in the order measured: every column, ``session_file``, ``time``.

        ``time`` is when the calibration's session was measured, else (its
        session unknown) when the calibration was made.
        """
        from sqlalchemy import func

        s, c = schema.sessions, schema.calibrations
        when = func.coalesce(c.c.measured_at, c.c.created)
        return self._rows(c, robot, when, [s.c.file.label("session_file"), when.label("time")])

    def sessions(self, robot: str) -> list[dict]:
        """A robot's sessions, oldest first (every column and ``tracker``)."""
        return self._rows(schema.sessions, robot, "measured_at")

    def verifications(self, robot: str) -> list[dict]:
        """A robot's ISO 9283 tests, oldest first (every column and ``tracker``)."""
        return self._rows(schema.verifications, robot, "measured_at")

    def path_verifications(self, robot: str) -> list[dict]:
        """A robot's ISO 9283 path tests (``verify --path``), oldest first."""
        return self._rows(schema.path_verifications, robot, "measured_at")

    def checks(self, robot: str) -> list[dict]:
        """A robot's checks, oldest first (every column)."""
        return self._rows(schema.checks, robot, "time")

    def circle_checks(self, robot: str) -> list[dict]:
        """A robot's quick circle tests (``check --circle``), oldest first (and ``tracker``)."""
        return self._rows(schema.circle_checks, robot, "time")

    def _rows(self, table: Any, robot: str, order: Any, more: list | None = None) -> list[dict]:
        from sqlalchemy import select

        r, s, t = schema.robots, schema.sessions, schema.trackers
        query = select(table, *(more or []))
        if table is schema.calibrations:
            query = query.outerjoin(s, s.c.id == table.c.session_id)
        if "tracker_id" in table.c:
            query = query.add_columns(t.c.name.label("tracker")).outerjoin(
                t, t.c.id == table.c.tracker_id
            )
        query = (
            query.join(r, r.c.id == table.c.robot_id)
            .where(r.c.name == robot)
            .order_by(table.c[order] if isinstance(order, str) else order, table.c.id)
        )
        with self._begin() as conn:
            if conn.execute(select(r.c.id).where(r.c.name == robot)).first() is None:
                names = [str(n) for (n,) in conn.execute(select(r.c.name).order_by(r.c.name))]
                known = ", ".join(names) if names else "none yet"
                raise HistoryError(f"no robot {robot!r} in the history {self.where} ({known})")
            return [dict(row._mapping) for row in conn.execute(query)]


def _session_file(named: str | None, calibration: Path) -> Path | None:
    """The session file a calibration names: as given (relative to where identify ran),
    else beside the calibration; ``None`` when neither is there."""
    if not named:
        return None
    for path in (Path(named), calibration.parent / named):
        if path.is_file():
            return path
    return None


def _tracker_parts(name: str | None) -> dict:
    """Model and serial of a ``vendor:model:serial`` tracker id (``{}`` otherwise)."""
    parts = (name or "").split(":")
    return {"model": parts[1], "serial": parts[2]} if len(parts) == 3 else {}


def check_usable(target: str | os.PathLike | None = None) -> None:
    """Refuse now a history a command could not record into at its end; create nothing.

    For ``identify``/``verify``/``check --history``: a bad URL, a file that is
    no history, a server that does not answer are refused before the
    command's work, and a history that is not there yet is not made by a
    command that may still fail (it is made when something is recorded).
    """
    url = resolve(target, create=False)
    engine = _engine(url, create=True)
    if engine.url.get_backend_name() == "sqlite":
        # Nothing connected: an existing file was probed read-only, a new one's folder checked.
        engine.dispose()
        return
    history = History(engine, engine.url.render_as_string(hide_password=True))
    try:
        history.upgrade(create=True, change=False)
    finally:
        history.close()


def open_history(target: str | os.PathLike | None = None, create: bool = True) -> History:
    """Open a history, creating or upgrading its schema (a context manager).

    Parameters
    ----------
    target : str or path-like, optional
        An SQLite file, ``sqlite:///FILE``, ``postgresql://USER@HOST/DB``;
        default ``$CALIBRATOR_HISTORY``, else :func:`default_path`.
    create : bool
        Create an SQLite file that does not exist (else: HistoryError).

    Returns
    -------
    History

    Raises
    ------
    HistoryError
        Not a file or URL, no such file (``create=False``), a database
        that is not a history, a newer schema, or a server that does not answer.
    """
    url = resolve(target, create)
    engine = _engine(url, create)
    where = (
        engine.history_where
        if engine.url.get_backend_name() == "sqlite"
        else (engine.url.render_as_string(hide_password=True))
    )
    history = History(engine, where)
    try:
        history.upgrade(create)
    except BaseException:
        history.close()
        raise
    return history
