"""Session loading checked against the raw arrays, never the loader's own helpers.

Every column holds values no other column can hold (distinct magnitudes), rows
are shuffled and stored as float32 the way another tool might write them, so
a swapped column, a lost sort or a lossy cast shows up as a wrong number.
"""

import json

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from scipy.spatial.transform import Rotation

from calibrator import robots, session
from calibrator.errors import SessionError

META = {"format": "calibrator.session", "version": 1, "frame": "tracker", "model": "ur10e"}
N = 7


def raw_arrays(seed=0):
    """Distinct values per column: x in 1000s, y in 2000s, z in -3000s; joints apart."""
    rng = np.random.default_rng(seed)
    q = (rng.uniform(-0.4, 0.4, (N, 6)) + np.arange(1, 7) * 0.5).astype(np.float32)
    points = (rng.uniform(0, 100, (N, 3)) + [1000.0, 2000.0, -3000.0]).astype(np.float32)
    rotvecs = (rng.uniform(-0.3, 0.3, (N, 3)) + [0.5, -1.0, 1.5]).astype(np.float32)
    poses = rng.permutation(np.arange(N) * 3 + 10)  # shuffled, not 0..N-1
    return poses, q, points, rotvecs


def write(path, columns, meta=META):
    table = pa.table(columns)
    if meta is not None:
        table = table.replace_schema_metadata({b"calibrator": json.dumps(meta).encode()})
    pq.write_table(table, path)
    return path


def foreign(poses, q, points, rotvecs=None):
    # Column order deliberately not the documented one.
    cols = {"z_mm": points[:, 2], "operator": ["x"] * len(poses)}
    cols.update({f"q{6 - i}_rad": pa.array(q[:, 5 - i], pa.float32()) for i in range(6)})
    cols.update(y_mm=pa.array(points[:, 1], pa.float32()), pose=pa.array(poses, pa.int32()))
    cols["x_mm"] = pa.array(points[:, 0], pa.float32())
    if rotvecs is not None:
        for i in (2, 1, 0):  # rz, ry, rx: reverse order
            cols[("rx_rad", "ry_rad", "rz_rad")[i]] = pa.array(rotvecs[:, i], pa.float32())
    return cols


def test_a_foreign_file_loads_into_exactly_the_expected_observations(tmp_path):
    poses, q, points, rotvecs = raw_arrays()
    path = write(tmp_path / "other.parquet", foreign(poses, q, points, rotvecs))
    obs = session.load(path).observations
    order = np.argsort(poses)  # rows come back sorted by pose number
    np.testing.assert_array_equal(obs.q, q[order].astype(np.float64))
    np.testing.assert_array_equal(obs.points, points[order].astype(np.float64))
    expected_rot = Rotation.from_rotvec(rotvecs[order].astype(np.float64)).as_matrix()
    np.testing.assert_allclose(obs.rotations, expected_rot, atol=1e-12)
    assert obs.q.dtype == np.float64 and obs.points.dtype == np.float64


def test_a_foreign_file_without_orientation_has_none(tmp_path):
    poses, q, points, _ = raw_arrays(1)
    loaded = session.load(write(tmp_path / "p.parquet", foreign(poses, q, points)))
    assert loaded.meta.tool_known is False  # not said: the tool point is identified
    obs = loaded.observations
    assert obs.rotations is None
    np.testing.assert_array_equal(obs.points, points[np.argsort(poses)])


def test_round_trip_equals_the_arrays_written(tmp_path):
    rng = np.random.default_rng(5)
    q = rng.uniform(-3, 3, (N, 6))
    points = rng.normal(0, 800, (N, 3))
    rotvecs = rng.normal(0, 1, (N, 3))
    # A nominal table of its own (not the named model's): the file must carry it.
    nominal = robots.get("er10l-c10").mdh + rng.normal(0, 0.1, (6, 5))
    meta = session.SessionMeta("base", nominal, "er10l-c10")
    path = tmp_path / "s.parquet"
    session.write(path, session.to_table(q, points, rotvecs), meta)
    loaded = session.load(path)
    obs = loaded.observations
    np.testing.assert_array_equal(obs.q, q)
    np.testing.assert_array_equal(obs.points, points)
    np.testing.assert_allclose(obs.rotations, Rotation.from_rotvec(rotvecs).as_matrix(), atol=1e-12)
    np.testing.assert_array_equal(loaded.meta.nominal_mdh, nominal)
    assert loaded.meta.frame == "base"


def refused(path):
    with pytest.raises(SessionError) as info:
        session.load(path)
    message = str(info.value)
    assert "\n" not in message and str(path) in message
    return message


@pytest.mark.parametrize("key", ["nominal_mdh", "flange2tool"])
@pytest.mark.parametrize("value", [np.nan, np.inf])
def test_non_finite_metadata_is_refused(tmp_path, key, value):
    poses, q, points, _ = raw_arrays()
    meta = dict(META)
    matrix = robots.get("ur10e").mdh.copy() if key == "nominal_mdh" else np.eye(4)
    matrix[2, 0 if key == "nominal_mdh" else 3] = value
    meta[key] = matrix.tolist()
    path = tmp_path / "m.parquet"
    # json writes NaN/Infinity literals, as Python-based tools do.
    write(path, foreign(poses, q, points), meta)
    assert key in refused(path)


def test_fractional_pose_numbers_are_refused(tmp_path):
    poses, q, points, _ = raw_arrays()
    cols = foreign(poses, q, points)
    cols["pose"] = pa.array(poses + 0.5, pa.float64())
    assert "pose" in refused(write(tmp_path / "f.parquet", cols))
    # A whole number stored as float is fine.
    cols["pose"] = pa.array(poses.astype(float), pa.float64())
    assert len(session.load(write(tmp_path / "w.parquet", cols)).observations) == N


def test_an_empty_session_is_refused(tmp_path):
    poses, q, points, _ = raw_arrays()
    cols = foreign(poses[:0], q[:0], points[:0])
    assert "no poses" in refused(write(tmp_path / "e.parquet", cols))


def test_an_unreadable_file_is_refused_with_the_readers_reason(tmp_path):
    junk = tmp_path / "junk.parquet"
    junk.write_bytes(b"PAR1" + bytes(range(256)) * 4)
    message = refused(junk)
    assert str(junk) in message and "not a readable Parquet file" in message
    reason = message.split("(", 1)[1].rstrip(")")
    assert len(reason.split()) > 2, reason  # the reader's own sentence, not a class name


def test_nan_rows_are_named_by_their_first_five_pose_numbers(tmp_path):
    poses, q, points, _ = raw_arrays()
    points = points.astype(np.float64)
    points[:, 1] = np.nan  # every row bad: the message names the first five
    message = refused(write(tmp_path / "n.parquet", foreign(poses, q, points)))
    assert "y_mm" in message
    assert str(poses[:5].tolist()) in message


@pytest.mark.parametrize("bad", ["points", "rotvecs"])
def test_rows_of_the_wrong_width_are_refused_when_building_a_table(bad):
    q, good = np.zeros((4, 6)), np.zeros((4, 3))
    arrays = {"points": good, "rotvecs": good, bad: np.zeros((4, 2))}
    with pytest.raises(ValueError):
        session.to_table(q, arrays["points"], arrays["rotvecs"])


@pytest.mark.parametrize(
    ("change", "words"),
    [
        (lambda c, m: (c.pop("y_mm"), c.pop("z_mm")), ["missing column(s) y_mm, z_mm"]),
        (
            lambda c, m: c.update(rx_rad=np.zeros(N), ry_rad=np.zeros(N)),
            ["needs all of rx_rad, ry_rad, rz_rad", "found only rx_rad, ry_rad"],
        ),
        (lambda c, m: c.update(q7_rad=np.zeros(N)), ["this program calibrates 6-axis arms"]),
        (
            lambda c, m: m.update(nominal_mdh=np.zeros((7, 5)).tolist()),
            ["7 joints", "this program calibrates 6-axis arms"],
        ),
        (lambda c, m: m.update(nominal_mdh=np.zeros((6, 4)).tolist()), ["'nominal_mdh' must be"]),
        (lambda c, m: m.update(flange2tool=np.zeros((3, 5)).tolist()), ["'flange2tool' must be"]),
        (lambda c, m: m.update(nominal_mdh=[["a"] * 5] * 6), ["'nominal_mdh'", "num"]),
        (lambda c, m: c.update(x_mm=pa.array([None] + [1.0] * (N - 1))), ["x_mm has NaN"]),
    ],
)
def test_refusals_name_what_is_wrong(tmp_path, change, words):
    poses, q, points, _ = raw_arrays()
    cols, meta = foreign(poses, q, points), dict(META)
    change(cols, meta)
    message = refused(write(tmp_path / "bad.parquet", cols, meta))
    for word in words:
        assert word in message


def test_optional_columns_and_a_pandas_index_survive_a_round_trip(tmp_path):
    rng = np.random.default_rng(9)
    q, points = rng.uniform(-3, 3, (N, 6)), rng.normal(0, 800, (N, 3))
    spread, n = rng.uniform(0, 0.01, (N, 3)), np.arange(N) + 5
    stamps = [f"2026-01-01T00:00:{i:02d}" for i in range(N)]
    table = session.to_table(q, points, spread=spread, n_readings=n, timestamps=stamps)
    frame = table.to_pandas()
    frame.index = np.arange(N) * 7 + 3  # an index a pandas user might carry along
    meta = session.SessionMeta("tracker", robots.get("ur5e").mdh, "ur5e")
    path = tmp_path / "o.parquet"
    session.write(path, frame, meta)
    loaded = session.load(path).table
    assert loaded.column_names == table.column_names
    assert loaded["n_readings"].to_pylist() == n.tolist()
    assert loaded["timestamp"].to_pylist() == stamps
    np.testing.assert_array_equal(loaded.to_pandas()[["sx_mm", "sy_mm", "sz_mm"]], spread)


@pytest.mark.parametrize(
    ("raw", "words"),
    [
        (b"{not json", ["metadata is not JSON"]),
        (b"[1, 2]", ["format is not"]),
        (json.dumps(dict(META, format="other")).encode(), ["format is not"]),
        (json.dumps(dict(META, frame="world")).encode(), ["'world'"]),
        (
            json.dumps(dict(META, flange2tool=np.diag([2.0, 1, 1, 1]).tolist())).encode(),
            ["flange2tool", "rotation"],
        ),
    ],
)
def test_bad_metadata_is_refused_naming_it(tmp_path, raw, words):
    poses, q, points, _ = raw_arrays()
    table = pa.table(foreign(poses, q, points)).replace_schema_metadata({b"calibrator": raw})
    path = tmp_path / "m.parquet"
    pq.write_table(table, path)
    message = refused(path)
    for word in words:
        assert word in message
