"""Fixtures of the history's tests: real files made by the commands, and a real PostgreSQL.

The PostgreSQL server comes from the ``pgserver`` package (a PostgreSQL 16
server in a wheel, in the ``test`` extra): started once per test session in
a temporary folder, each test gets a database of its own on it.
"""

import itertools
import shutil
import tempfile
from pathlib import Path

import pytest
from cli_kit import cli

_numbers = itertools.count()


@pytest.fixture(scope="session")
def pg_server():
    """A PostgreSQL server this test session started, in a data folder of its own.

    Run as root, pgserver runs the server as its own user, which must reach
    the folder: not under pytest's temporary folders, which pytest keeps
    private to root (mode 700).
    """
    import pgserver

    folder = tempfile.mkdtemp(prefix="calibrator-pg-")
    server = pgserver.get_server(folder, cleanup_mode="stop")
    # A server thrown away after the tests need not sync to disk: its stop (a
    # checkpoint) took 7-18 s on the loaded machine with syncing.
    server.psql("ALTER SYSTEM SET fsync = off;")
    server.psql("ALTER SYSTEM SET synchronous_commit = off;")
    server.psql("SELECT pg_reload_conf();")
    yield server
    server.cleanup()
    shutil.rmtree(folder, ignore_errors=True)


def new_pg_database(server) -> str:
    """A fresh, empty database on ``server``: its URL."""
    name = f"history_{next(_numbers)}"
    server.psql(f"CREATE DATABASE {name};")
    return server.get_uri(name)


@pytest.fixture
def new_pg(pg_server):
    """A maker of fresh databases on the test session's server (their URLs).

    A fixture rather than an import: ``conftest`` is no importable name when
    several test folders have one.
    """
    return lambda: new_pg_database(pg_server)


@pytest.fixture(params=["sqlite", "postgresql"])
def history_url(request, tmp_path):
    """An empty history target on each backend: an SQLite file, a PostgreSQL database."""
    if request.param == "sqlite":
        return str(tmp_path / "history.sqlite")
    return new_pg_database(request.getfixturevalue("pg_server"))


@pytest.fixture(scope="session")
def measured(tmp_path_factory) -> Path:
    """A folder as a user has it: three sessions of one simulated arm, their
    calibrations (identify), and an ISO 9283 test (verify, recorded in
    ``verify-history.sqlite`` by ``--history``), made by the commands."""
    folder = tmp_path_factory.mktemp("measured")
    for i, noise in enumerate(("0.02", "0.04", "0.06")):
        session = f"s{i}.parquet"
        result = cli("simulate", "--seed", "3", "--noise-mm", noise, "-o", session, cwd=folder)
        assert result.code == 0, result.stderr
        result = cli("identify", session, "-o", f"cal{i}.json", "--method", "lm", cwd=folder)
        assert result.code == 0, result.stderr
    result = cli(
        "verify", "--model", "er10l-c10", "--cycles", "2", "--readings", "1", "-q",
        "--seed", "3", "-o", "verify.json", "--history", "verify-history.sqlite", cwd=folder,
    )  # fmt: skip
    assert result.code == 0, result.stderr
    return folder
