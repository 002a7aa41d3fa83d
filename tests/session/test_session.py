"""Session file v1: round trip, files from other writers, and every bad input."""

import json

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from calibrator import robots, session
from calibrator.errors import SessionError
from calibrator.model import rotations
from calibrator.simulate import simulate


def write_foreign(path, columns, meta, metadata_key=b"calibrator"):
    """Write a session the way another program would: pyarrow only, no pandas index."""
    table = pa.table(columns)
    if meta is not None:
        table = table.replace_schema_metadata({metadata_key: json.dumps(meta).encode()})
    pq.write_table(table, path)
    return path


def foreign_columns(n=8, seed=0):
    rng = np.random.default_rng(seed)
    q = rng.uniform(-1, 1, (n, 6))
    cols = {
        "x_mm": rng.normal(0, 500, n),
        "y_mm": rng.normal(0, 500, n),
        "z_mm": rng.normal(0, 500, n),
        "pose": pa.array(np.arange(n)[::-1], pa.int32()),
    }
    cols.update({f"q{i + 1}_rad": pa.array(q[:, i], pa.float32()) for i in range(6)})
    cols["operator_note"] = ["ok"] * n
    return cols


BASE_META = {"format": "calibrator.session", "version": 1, "frame": "tracker", "model": "ur5e"}


def test_round_trip_keeps_rows_and_metadata(tmp_path):
    table, meta, _ = simulate(model="er10l-c10", poses=6, seed=1, noise_mm=0.02)
    path = tmp_path / "s.parquet"
    session.write(path, table, meta)
    loaded = session.load(path)
    assert loaded.table.equals(table)
    assert loaded.meta.frame == "base" and loaded.meta.model == "er10l-c10"
    np.testing.assert_array_equal(loaded.meta.nominal_mdh, robots.get("er10l-c10").mdh)
    assert loaded.meta.extra["simulated"]["seed"] == 1
    obs = loaded.observations
    np.testing.assert_allclose(
        obs.rotations, rotations.rotvec_to_matrix(loaded.array(session.ROTVEC_COLUMNS))
    )
    assert not list(tmp_path.glob(".*tmp"))  # the atomic write left nothing behind


def test_a_file_written_by_another_tool_loads(tmp_path):
    path = write_foreign(tmp_path / "other.parquet", foreign_columns(), BASE_META)
    loaded = session.load(path)
    assert loaded.table["pose"].to_pylist() == list(range(8))  # sorted by pose
    assert loaded.observations.q.shape == (8, 6) and loaded.observations.rotations is None
    np.testing.assert_array_equal(loaded.meta.nominal_mdh, robots.get("ur5e").mdh)
    np.testing.assert_array_equal(loaded.meta.flange2tool, np.eye(4))


def test_nominal_mdh_in_the_file_is_used(tmp_path):
    mdh = robots.get("ur10e").mdh + 0.5
    meta = dict(BASE_META, nominal_mdh=mdh.tolist())
    del meta["model"]
    loaded = session.load(write_foreign(tmp_path / "m.parquet", foreign_columns(), meta))
    np.testing.assert_allclose(loaded.meta.nominal_mdh, mdh)
    assert loaded.meta.model is None


def bad(tmp_path, columns=None, meta=BASE_META, **kwargs):
    cols = foreign_columns() if columns is None else columns
    return write_foreign(tmp_path / "bad.parquet", cols, meta, **kwargs)


@pytest.mark.parametrize(
    ("mutate", "message"),
    [
        (lambda c, m: c.pop("y_mm"), "missing column.*y_mm"),
        (lambda c, m: c.update(q3_rad=["a"] * 8), "q3_rad is not numeric"),
        (lambda c, m: c.update(x_mm=np.r_[np.nan, np.zeros(7)]), "x_mm has NaN or infinite"),
        (lambda c, m: c.update(z_mm=np.r_[np.zeros(7), np.inf]), "z_mm has NaN or infinite"),
        (lambda c, m: c.update(pose=np.r_[0, np.arange(7)]), "duplicate pose"),
        (lambda c, m: c.update(q7_rad=np.zeros(8)), "more than 6 joints"),
        (lambda c, m: c.update(rx_rad=np.zeros(8)), "orientation needs all of"),
        (lambda c, m: m.update(model="kr16"), "unknown model 'kr16'"),
        (lambda c, m: m.update(frame="world"), "'frame' must be 'base' or 'tracker'"),
        (lambda c, m: m.update(version=7), "version 7 is not supported"),
        (
            lambda c, m: (m.pop("model"), m.update(nominal_mdh=np.zeros((7, 5)).tolist())),
            "7 joints",
        ),
        (lambda c, m: m.pop("model"), "neither 'model' nor 'nominal_mdh'"),
        (lambda c, m: m.update(flange2tool=np.eye(3).tolist()), "'flange2tool' must be"),
    ],
)
def test_bad_sessions_are_refused_with_one_line(tmp_path, mutate, message):
    cols, meta = foreign_columns(), dict(BASE_META)
    mutate(cols, meta)
    with pytest.raises(SessionError, match=message) as info:
        session.load(bad(tmp_path, cols, meta))
    assert "\n" not in str(info.value)


def test_missing_file_not_parquet_and_no_metadata(tmp_path):
    with pytest.raises(SessionError, match="not found"):
        session.load(tmp_path / "nope.parquet")
    text = tmp_path / "text.parquet"
    text.write_text("pose,x_mm\n1,2\n")
    with pytest.raises(SessionError, match="not a readable Parquet file"):
        session.load(text)
    with pytest.raises(SessionError, match="no 'calibrator' metadata"):
        session.load(bad(tmp_path, meta=None))


def test_model_option_overrides_the_file(tmp_path):
    loaded = session.load(bad(tmp_path), model="ur10e")
    np.testing.assert_array_equal(loaded.meta.nominal_mdh, robots.get("ur10e").mdh)
