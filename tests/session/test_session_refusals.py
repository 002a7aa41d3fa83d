"""Session files written by pyarrow alone, refused with exactly the documented line.

Each file is built here column by column (no ``session.to_table``), as a
foreign tool would write it; every refusal is compared in full, since the
line is all a user gets.
"""

import json

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from scipy.spatial.transform import Rotation

from calibrator import robots, session
from calibrator.errors import SessionError
from calibrator.model import kinematics

META = {"format": "calibrator.session", "version": 1, "frame": "tracker", "model": "ur5e"}
N = 6


def columns(seed=0):
    rng = np.random.default_rng(seed)
    cols = {"pose": pa.array(np.arange(N)[::-1] * 2, pa.int64())}
    q = rng.uniform(-1.0, 1.0, (N, 6))
    cols.update({f"q{i + 1}_rad": q[:, i] for i in range(6)})
    points = rng.normal(0.0, 300.0, (N, 3)) + [300.0, 100.0, 400.0]
    cols.update(x_mm=points[:, 0], y_mm=points[:, 1], z_mm=points[:, 2])
    return cols


def write(path, cols, meta=META, raw=None):
    table = pa.table(cols)
    value = raw if raw is not None else json.dumps(meta).encode()
    if meta is not None or raw is not None:
        table = table.replace_schema_metadata({b"calibrator": value})
    pq.write_table(table, path)
    return path


def refusal(path, **kwargs):
    with pytest.raises(SessionError) as info:
        session.load(path, **kwargs)
    return str(info.value)


def floats(values):
    return np.asarray(values, dtype=float)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda c, m: m.update(version=2), "session version 2 is not supported "
         "(this program reads version 1, a JSON integer)"),
        (lambda c, m: m.update(version=True), "session version True is not supported "
         "(this program reads version 1, a JSON integer)"),
        (lambda c, m: m.update(format="x"), "metadata format is not 'calibrator.session'"),
        (lambda c, m: m.update(frame=3), "metadata 'frame' must be 'base' or 'tracker', got 3"),
        (lambda c, m: m.pop("frame"), "metadata 'frame' must be 'base' or 'tracker', got None"),
        (lambda c, m: m.update(model=7), "metadata 'model' must be a string, got 7"),
        (lambda c, m: m.update(tool_known="no"),
         "metadata 'tool_known' must be true or false (JSON booleans), got 'no'"),
        (lambda c, m: m.pop("model"), "metadata names neither 'model' nor 'nominal_mdh'"),
        (lambda c, m: m.update(model="kr16"),
         "unknown model 'kr16'; known: " + ", ".join(robots.names())),
        (lambda c, m: m.update(flange2tool=[[1, 0], [0, 1]]),
         "metadata 'flange2tool' must be (4, 4), got (2, 2)"),
        (lambda c, m: m.update(flange2tool=[[1, 0, 0, 0]] * 3 + [[0, 0, 0, "1"]]),
         "metadata 'flange2tool' must be a table (list of lists) of JSON numbers"),
        (lambda c, m: m.update(nominal_mdh=[[0.0] * 5] * 5),
         "'nominal_mdh' has 5 joints; this program calibrates 6-axis arms"),
        (lambda c, m: m.update(nominal_mdh=[[0.0] * 4] * 6),
         "metadata 'nominal_mdh' must be (6, 5), got (6, 4)"),
        (lambda c, m: m.update(nominal_mdh=[[float("nan")] * 5] * 6),
         "the 'calibrator' metadata: nominal_mdh[0][0]: NaN is not allowed (strict JSON)"),
        (lambda c, m: m.update(flange2tool=np.diag([1.0, 1, -1, 1]).tolist()),
         "flange2tool rotation part is not a proper rotation"),
        (lambda c, m: c.update(q0_rad=np.zeros(N), q9_rad=np.zeros(N)),
         "columns ['q0_rad', 'q9_rad'] imply more than 6 joints; "
         "this program calibrates 6-axis arms"),
        (lambda c, m: (c.pop("pose"), c.pop("z_mm")), "missing column(s) pose, z_mm"),
        (lambda c, m: c.update(rz_rad=np.zeros(N), rx_rad=np.zeros(N)),
         "orientation needs all of rx_rad, ry_rad, rz_rad, found only rx_rad, rz_rad"),
        (lambda c, m: c.update(y_mm=pa.array(["1"] * N)), "column y_mm is not numeric (string)"),
        (lambda c, m: c.update(q4_rad=pa.array(np.zeros(N), pa.float16())),
         "column q4_rad is float16 (about 3 significant digits); store float32 or float64"),
        (lambda c, m: c.update(x_mm=floats([1, 2, np.nan, 4, np.inf, 6])),
         "column x_mm has NaN or infinite values (pose [6, 2])"),
        (lambda c, m: c.update(rx_rad=floats([0, 0, 0, 0, 0, -100.5]), ry_rad=np.zeros(N),
                               rz_rad=np.zeros(N)),
         "column rx_rad has absurd values (beyond 100 rad)"),
        (lambda c, m: c.update(sz_mm=floats([0.1, 0, 0, -1e-9, 0, 0])),
         "column sz_mm (a standard deviation) has negative values"),
        (lambda c, m: c.update(pose=pa.array([0, 1, None, 3, 4, 5])),
         "column pose has NaN, infinite or null values"),
        (lambda c, m: c.update(pose=floats([0, 1, 2, 3, 4, np.nan])),
         "column pose has NaN, infinite or null values"),
        (lambda c, m: c.update(pose=floats([0, 1, 2, 3, 4, 5.5])),
         "column pose must hold whole numbers"),
        (lambda c, m: c.update(pose=floats([0, 1, 2, 3, 4, 2.0**54])),
         "column pose must hold whole numbers"),
        (lambda c, m: c.update(pose=pa.array([9, 9, 7, 7, 1, 1])),
         "duplicate pose number(s) [1, 7, 9]"),
    ],
)  # fmt: skip
def test_each_refusal_is_one_exact_line_naming_the_file(tmp_path, change, message):
    cols, meta = columns(), dict(META)
    change(cols, meta)
    path = write(tmp_path / "bad.parquet", cols, meta)
    assert refusal(path) == f"{path}: {message}"


def test_refusals_before_the_metadata_is_read(tmp_path):
    folder = tmp_path / "folder.parquet"
    folder.mkdir()
    assert refusal(folder) == f"session file not found: {folder}"
    bare = write(tmp_path / "bare.parquet", columns(), None)
    assert refusal(bare) == f"{bare} has no 'calibrator' metadata (not a session file v1)"
    garbled = write(tmp_path / "g.parquet", columns(), raw=b"{oops")
    assert refusal(garbled) == f"{garbled}: the 'calibrator' metadata is not JSON"


def test_only_the_first_five_duplicates_and_bad_rows_are_listed(tmp_path):
    cols = columns()
    cols.update({k: np.tile(v, 2) for k, v in cols.items() if k != "pose"})
    cols["pose"] = pa.array([5, 5, 4, 4, 3, 3, 2, 2, 1, 1, 0, 0])
    path = write(tmp_path / "d.parquet", cols)
    assert refusal(path).endswith("duplicate pose number(s) [0, 1, 2, 3, 4]")
    cols = columns()
    cols.update({k: np.tile(v, 2) for k, v in cols.items() if k != "pose"})
    cols["pose"] = pa.array(np.arange(12) + 20)
    cols["y_mm"] = np.full(12, np.nan)
    path = write(tmp_path / "n.parquet", cols)
    assert refusal(path).endswith(
        "column y_mm has NaN or infinite values (pose [20, 21, 22, 23, 24])"
    )


def test_loaded_rows_are_sorted_and_read_as_written(tmp_path):
    cols = columns(1)
    rotvecs = Rotation.random(N, random_state=2).as_rotvec()
    cols.update(rx_rad=rotvecs[:, 0], ry_rad=rotvecs[:, 1], rz_rad=rotvecs[:, 2])
    cols.update(sx_mm=np.full(N, 0.0), sy_mm=np.full(N, 0.01), sz_mm=np.full(N, 0.02))
    path = write(tmp_path / "ok.parquet", cols, dict(META, tool_known=True, operator="ann"))
    loaded = session.load(path)
    order = np.argsort(cols["pose"].to_numpy())
    assert loaded.table["pose"].to_pylist() == [0, 2, 4, 6, 8, 10]
    obs = loaded.observations
    np.testing.assert_array_equal(
        obs.points, np.column_stack([cols["x_mm"], cols["y_mm"], cols["z_mm"]])[order]
    )
    np.testing.assert_array_equal(
        obs.q, np.column_stack([cols[f"q{i}_rad"] for i in range(1, 7)])[order]
    )
    np.testing.assert_allclose(
        obs.rotations, Rotation.from_rotvec(rotvecs[order]).as_matrix(), atol=1e-15
    )
    np.testing.assert_array_equal(loaded.array(("sz_mm", "sx_mm")), [[0.02, 0.0]] * N)
    meta = loaded.meta
    assert meta.tool_known is True and meta.model == "ur5e" and meta.frame == "tracker"
    assert meta.extra == {"operator": "ann"}
    np.testing.assert_array_equal(meta.flange2tool, np.eye(4))
    assert loaded.warnings == []


def test_a_model_given_by_the_caller_replaces_the_files_table_and_name(tmp_path):
    own = (robots.get("ur5e").mdh + 0.25).tolist()
    path = write(tmp_path / "m.parquet", columns(), dict(META, nominal_mdh=own))
    from_file = session.load(path).meta
    np.testing.assert_array_equal(from_file.nominal_mdh, own)
    assert from_file.model == "ur5e"
    overridden = session.load(path, model=" UR10E ").meta
    np.testing.assert_array_equal(overridden.nominal_mdh, robots.get("ur10e").mdh)
    assert overridden.model == "ur10e"


def test_joint_limits_come_from_the_named_model_only(tmp_path):
    cols = columns()
    cols["q3_rad"] = floats([0.1, 0.2, 3.3, 0.1, 0.2, 0.3])  # elbow beyond +-pi
    named = write(tmp_path / "named.parquet", cols)
    assert "q3_rad" in refusal(named)
    custom = dict(META, model="my-arm", nominal_mdh=robots.get("ur5e").mdh.tolist())
    loaded = session.load(write(tmp_path / "custom.parquet", cols, custom))
    assert loaded.meta.model == "my-arm"


def test_metadata_json_keeps_extra_keys_under_the_known_ones():
    meta = session.SessionMeta(
        "base", np.zeros((6, 5)), None, np.eye(4), np.bool_(True), {"version": 9, "note": "n"}
    )
    doc = meta.to_json()
    assert doc["version"] == 1 and doc["format"] == "calibrator.session" and doc["note"] == "n"
    assert doc["tool_known"] is True and "model" not in doc
    assert doc["nominal_mdh"] == [[0.0] * 5] * 6 and doc["flange2tool"] == np.eye(4).tolist()
    assert session.SessionMeta("tracker", np.zeros((6, 5)), "ur5e").to_json()["model"] == "ur5e"
    assert session.SessionMeta("tracker", np.zeros((6, 5))).to_json()["tool_known"] is False


def test_written_sessions_keep_other_footer_keys_and_read_back(tmp_path):
    q = np.linspace(-1, 1, 18).reshape(3, 6)
    points = kinematics.forward(robots.get("ur5e").mdh, q)[:, :3, 3] + [2000.0, 0.0, 0.0]
    table = session.to_table(q, points, n_readings=[3, 4, 5], timestamps=["a", "b", "c"])
    assert table.column_names == [
        "pose",
        *session.JOINT_COLUMNS,
        *session.POINT_COLUMNS,
        "n_readings",
        "timestamp",
    ]
    assert table["pose"].to_pylist() == [0, 1, 2] and table.schema.field("pose").type == pa.int64()
    assert table.schema.field("n_readings").type == pa.int64()
    table = table.replace_schema_metadata({b"origin": b"lab 3"})
    meta = session.SessionMeta("tracker", robots.get("ur5e").mdh, "ur5e")
    session.write(tmp_path / "w.parquet", table, meta)
    footer = pq.read_schema(tmp_path / "w.parquet").metadata
    assert footer[b"origin"] == b"lab 3"
    assert json.loads(footer[b"calibrator"]) == meta.to_json()
    loaded = session.load(tmp_path / "w.parquet")
    np.testing.assert_array_equal(loaded.observations.points, points)
    assert loaded.table["timestamp"].to_pylist() == ["a", "b", "c"]


def test_whole_float_pose_numbers_load_up_to_two_to_the_53(tmp_path):
    cols = columns()
    cols["pose"] = floats([1000.0, 250.0, 2.0**53, 7.0, 0.0, 12345.0])
    loaded = session.load(write(tmp_path / "f.parquet", cols))
    assert loaded.table["pose"].to_pylist() == [0.0, 7.0, 250.0, 1000.0, 12345.0, 2.0**53]


def test_rotation_vectors_up_to_100_rad_are_accepted(tmp_path):
    cols = columns()
    cols.update(rx_rad=floats([100.0, -100.0, 0, 0, 0, 0]), ry_rad=np.zeros(N), rz_rad=np.zeros(N))
    loaded = session.load(write(tmp_path / "r.parquet", cols))
    assert sorted(loaded.table["rx_rad"].to_pylist()) == [-100.0, 0, 0, 0, 0, 100.0]


def test_an_integer_nominal_table_is_read_as_floats(tmp_path):
    table = np.rint(robots.get("ur5e").mdh).astype(int).tolist()
    meta = session.load(
        write(tmp_path / "i.parquet", columns(), dict(META, nominal_mdh=table))
    ).meta
    assert meta.nominal_mdh.dtype == np.float64
    np.testing.assert_array_equal(meta.nominal_mdh, table)


def test_a_ragged_table_in_the_metadata_is_refused(tmp_path):
    ragged = [[1, 0, 0, 0], [0, 1, 0], [0, 0, 1, 0], [0, 0, 0, 1]]
    path = write(tmp_path / "g.parquet", columns(), dict(META, flange2tool=ragged))
    assert refusal(path) == f"{path}: metadata 'flange2tool' is not a numeric table"


def test_a_long_tool_in_the_metadata_is_part_of_the_plausibility_check(tmp_path):
    # A 1.5 m tool triples the distances between points: consistent with the
    # tool the file names, not with the bare flange.
    tool = np.eye(4)
    tool[:3, 3] = [1500.0, 0.0, 300.0]
    q = np.random.default_rng(0).uniform(-3.0, 3.0, (20, 6))
    points = kinematics.forward(robots.get("ur5e").mdh, q, tool)[:, :3, 3]
    cols = {"pose": pa.array(np.arange(20), pa.int64())}
    cols.update({f"q{i + 1}_rad": q[:, i] for i in range(6)})
    cols.update(x_mm=points[:, 0], y_mm=points[:, 1], z_mm=points[:, 2])
    loaded = session.load(
        write(tmp_path / "t.parquet", cols, dict(META, flange2tool=tool.tolist()))
    )
    assert loaded.warnings == []
    bare = session.load(write(tmp_path / "b.parquet", cols))
    assert len(bare.warnings) == 1 and "2.9" in bare.warnings[0]


def test_tables_built_from_integers_store_floats_and_counts():
    q = np.zeros((2, 6), dtype=int)
    ints = np.array([[100, 200, 300], [400, 500, 600]])
    table = session.to_table(
        q, ints, rotvecs=ints // 100, spread=ints // 100, n_readings=[3.0, 4.0]
    )
    for name in (*session.POINT_COLUMNS, *session.ROTVEC_COLUMNS, *session.SPREAD_COLUMNS):
        assert table.schema.field(name).type == pa.float64(), name
    assert table.schema.field("n_readings").type == pa.int64()
    assert table["n_readings"].to_pylist() == [3, 4]
    assert table["sz_mm"].to_pylist() == [3.0, 6.0]


def test_spreads_of_the_wrong_width_are_refused():
    with pytest.raises(ValueError):
        session.to_table(np.zeros((2, 6)), np.zeros((2, 3)), spread=np.zeros((2, 2)))
