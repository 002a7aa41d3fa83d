"""The shipped migrations: they build the schema the code uses, and upgrade an older history."""

import sqlite3
from datetime import date, datetime

import pytest
from history_kit import check_doc

from calibrator.history import HistoryError, migrations, open_history, schema, store


def test_head_is_the_newest_script():
    from alembic.script import ScriptDirectory

    scripts = ScriptDirectory.from_config(migrations.config())
    assert scripts.get_current_head() == migrations.HEAD
    assert [s.revision for s in reversed(list(scripts.walk_revisions()))] == list(
        migrations.REVISIONS
    )


def test_migrated_schema_is_the_code_schema(history_url):
    """Alembic's own comparison finds no difference between the migrated database and schema.py."""
    from alembic.autogenerate import compare_metadata
    from alembic.migration import MigrationContext

    with open_history(history_url) as h, h.engine.connect() as conn:
        diff = compare_metadata(MigrationContext.configure(conn), schema.metadata)
    assert diff == []


def _at_revision_1(url):
    """A history written by the previous version: schema 0001 and a check in it."""
    engine = store._engine(store.resolve(url), create=True)
    with engine.begin() as conn:
        migrations.upgrade(conn, "0001")
        conn.exec_driver_sql("INSERT INTO robots (id, name, model) VALUES (1, 'arm-1', 'ur5e')")
        conn.exec_driver_sql(
            "INSERT INTO trackers (id, name, model, serial) "
            "VALUES (1, 'leica:AT960:7', 'AT960', '7')"
        )
        assert migrations.current(conn) == "0001"
    engine.dispose()


def test_a_history_at_revision_1_is_upgraded(history_url):
    _at_revision_1(history_url)
    with open_history(history_url) as h:
        with h.engine.connect() as conn:
            assert migrations.current(conn) == migrations.HEAD
        assert h.robots()[0]["name"] == "arm-1"
        assert h.trackers() == [
            {"name": "leica:AT960:7", "model": "AT960", "serial": "7", "certificate_date": None}
        ]
        h.describe_tracker("leica:AT960:7", certificate_date=date(2026, 2, 1))
        assert h.trackers()[0]["certificate_date"] == date(2026, 2, 1)
        h.record_check(check_doc(robot="arm-1"))
        assert len(h.checks("arm-1")) == 1


def test_a_newer_history_is_refused(tmp_path):
    path = tmp_path / "h.sqlite"
    with open_history(path):
        pass
    with sqlite3.connect(path) as conn:
        conn.execute("UPDATE alembic_version SET version_num = '0099'")
    with pytest.raises(HistoryError, match="revision 0099, newer than this calibrator reads"):
        open_history(path)


def test_an_upgrade_to_revision_3_files_old_calibrations_under_their_session_time(history_url):
    """Revision 0003 fills ``calibrations.measured_at`` from the sessions already recorded."""
    engine = store._engine(store.resolve(history_url), create=True)
    with engine.begin() as conn:
        migrations.upgrade(conn, "0002")
        conn.exec_driver_sql("INSERT INTO robots (id, name) VALUES (1, 'arm-1')")
        conn.exec_driver_sql(
            "INSERT INTO sessions (id, robot_id, sha256, file, measured_at, poses, conditions) "
            f"VALUES (1, 1, '{'a' * 64}', 's.parquet', '2026-03-01 08:00:00', 30, '{{}}')"
        )
        for number, session_id in ((1, "1"), (2, "NULL")):
            conn.exec_driver_sql(
                "INSERT INTO calibrations (id, robot_id, session_id, sha256, created, parameters, "
                f"uncertainties, statistics, provenance) VALUES ({number}, 1, {session_id}, "
                f"'{str(number) * 64}', '2026-06-0{number} 12:00:00', '{{}}', '{{}}', '{{}}', "
                "'{}')"
            )
    engine.dispose()
    with open_history(history_url) as h:
        first, second = h.calibrations("arm-1")
    assert first["measured_at"] == first["time"] == datetime(2026, 3, 1, 8)
    # No session known: filed under when it was made.
    assert second["measured_at"] is None and second["time"] == datetime(2026, 6, 2, 12)
