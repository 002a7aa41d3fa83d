"""verify --path results in the history: their own table (migration 0004), figures and all."""

import json

import pytest
from cli_kit import cli

from calibrator.history import HistoryError, migrations, open_history, records, store


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """Two line tests of seed 3's arm recorded as verify writes them: nominal, then 10 %."""
    folder = tmp_path_factory.mktemp("pathhist")
    for name, speed in (("a.json", "400"), ("b.json", "10%")):
        done = cli(
            "verify", "--seed", "3", "--path", "line", "--cycles", "2", "--path-speed", speed,
            "-o", name, "--history", "h.db", cwd=folder,
        )  # fmt: skip
        assert done.code == 0, done.stderr
        assert "recorded verification" in done.stdout
    return folder


def test_path_tests_are_rows_of_their_own_table_with_their_figures(recorded):
    with open_history(str(recorded / "h.db")) as h:
        rows = h.path_verifications("sim:ur10e:seed=3")
        assert h.verifications("sim:ur10e:seed=3") == []  # the pose tests' table is untouched
    assert len(rows) == 2
    for row, name in zip(rows, ("a.json", "b.json"), strict=True):
        doc = json.loads((recorded / name).read_text())
        path = doc["path"]
        assert row["shape"] == "line" and row["compensated"] is False
        assert row["at_p_mm"] == path["AT_P_mm"] and row["rt_p_mm"] == path["RT_P_mm"]
        assert row["av_pct"] == path["AV_pct"] and row["fv_mm_s"] == path["FV_mm_s"]
        assert row["speed_mm_s"] == path["speed_mm_s"]
        assert row["document"] == doc and row["tracker"]
    assert rows[0]["speed_mm_s"] == 400.0
    assert rows[1]["speed_mm_s"] == pytest.approx(
        0.1 * rows[1]["document"]["path"]["rated_speed_mm_s"]
    )


def test_recording_the_same_file_again_is_the_same_row(recorded):
    with open_history(str(recorded / "h.db")) as h:
        first = h.record_verification(recorded / "a.json")
        again = h.record_verification(recorded / "a.json")
        assert first == again and len(h.path_verifications("sim:ur10e:seed=3")) == 2


def test_a_path_test_without_a_figure_is_refused_naming_it(recorded, tmp_path):
    doc = json.loads((recorded / "a.json").read_text())
    del doc["path"]["RT_P_mm"]
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(doc))
    with pytest.raises(HistoryError, match="'RT_P_mm' must be a finite number"):
        records.verification(bad)


def test_a_history_at_0003_gains_the_table_on_opening(tmp_path):
    url = str(tmp_path / "old.db")
    engine = store._engine(store.resolve(url), create=True)
    with engine.begin() as conn:
        migrations.upgrade(conn, "0003")
        assert "path_verifications" not in _tables(conn)
    engine.dispose()
    with open_history(url) as h, h.engine.connect() as conn:
        assert "path_verifications" in _tables(conn)


def _tables(conn):
    from sqlalchemy import inspect

    return set(inspect(conn).get_table_names())
