"""Session files: plausible or refused (issue 8, items 6 and 7).

Item 6: data in the wrong units is refused before fitting, with a message
that names the likely mistake. Item 7: metadata values have their JSON
types, and odd columns or values get one line (a SessionError), never a
traceback or a silently different meaning.
"""

import json

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from cli_process_kit import run_cli

from calibrator import session
from calibrator.errors import CalibrationError, SessionError
from calibrator.model import plausibility
from calibrator.simulate import simulate

RAD2DEG = 180.0 / np.pi


def _write(path, table, meta):
    table = table.replace_schema_metadata({b"calibrator": json.dumps(meta).encode()})
    pq.write_table(table, path)
    return path


def _simulated(model="er10l-c10", frame="base", poses=30, seed=4, **kw):
    errors = "seed" if model == "er10l-c10" else "random"
    table, meta, _ = simulate(model=model, poses=poses, seed=seed, frame=frame, errors=errors, **kw)
    return table, meta.to_json()


def _scaled(table, columns, factor):
    for name in columns:
        i = table.column_names.index(name)
        values = np.asarray(table[name].to_pylist(), dtype=float) * factor
        table = table.set_column(i, name, pa.array(values))
    return table


POINTS = list(session.POINT_COLUMNS)
JOINTS = list(session.JOINT_COLUMNS)


# ---------------------------------------------------------------- item 6: units


@pytest.mark.parametrize("model", ["er10l-c10", "ur10e"])
@pytest.mark.parametrize("frame", ["base", "tracker"])
def test_plausible_sessions_load_without_warnings(tmp_path, model, frame):
    table, meta = _simulated(model, frame, tool_offset_mm=80.0)
    loaded = session.load(_write(tmp_path / "s.parquet", table, meta))
    assert loaded.warnings == []


@pytest.mark.parametrize(
    ("factor", "unit"),
    [(1e-3, "metres"), (0.1, "centimetres"), (1 / 25.4, "inches"), (1e3, "micrometres")],
)
@pytest.mark.parametrize("frame", ["base", "tracker"])
def test_points_in_another_unit_are_refused_naming_it(tmp_path, factor, unit, frame):
    table, meta = _simulated(frame=frame)
    path = _write(tmp_path / "s.parquet", _scaled(table, POINTS, factor), meta)
    with pytest.raises(SessionError, match=unit):
        session.load(path)


@pytest.mark.parametrize("model", ["er10l-c10", "ur5e", "ur10e"])
@pytest.mark.parametrize("seed", [3, 4])
def test_joints_in_degrees_are_refused_naming_degrees(tmp_path, model, seed):
    table, meta = _simulated(model, seed=seed)  # UR joints span +-360 deg
    path = _write(tmp_path / "s.parquet", _scaled(table, JOINTS, RAD2DEG), meta)
    with pytest.raises(SessionError, match="degrees"):
        session.load(path)


def test_small_joint_values_in_degrees_do_not_pass_as_radians(tmp_path):
    """Every value is inside the limits in rad, but the points then do not fit the model."""
    rng = np.random.default_rng(2)
    table, meta = _simulated("ur10e", poses=30)
    q = rng.uniform(-3.0, 3.0, (30, 6))  # degrees, small: would be legal radians
    from calibrator.model import kinematics

    points = kinematics.forward(np.asarray(meta["nominal_mdh"]), q / RAD2DEG)[:, :3, 3]
    for i, name in enumerate(JOINTS):
        table = table.set_column(table.column_names.index(name), name, pa.array(q[:, i]))
    for i, name in enumerate(POINTS):
        table = table.set_column(table.column_names.index(name), name, pa.array(points[:, i]))
    meta["flange2tool"] = np.eye(4).tolist()
    with pytest.raises(SessionError, match="degrees"):
        session.load(_write(tmp_path / "s.parquet", table, meta))


def test_joint_beyond_the_model_limits_is_refused(tmp_path):
    table, meta = _simulated()
    q1 = np.asarray(table["q1_rad"].to_pylist())
    q1[3] = 3.5  # er10l-c10 allows [-pi, pi]
    table = table.set_column(table.column_names.index("q1_rad"), "q1_rad", pa.array(q1))
    with pytest.raises(SessionError, match=r"pose 3.*q1_rad"):
        session.load(_write(tmp_path / "s.parquet", table, meta))


def test_deltas_after_fit_are_judged_against_plausible_ranges():
    from calibrator import robots

    nominal = robots.get("ur10e").mdh
    small = nominal + np.array([0.3, 1e-3, 1e-3, 0.3, 1e-3])  # mm and rad, per column
    assert plausibility.check_deltas(nominal, small) == []
    far = nominal.copy()
    far[1, 0] += 40.0  # a2 off by 40 mm
    (message,) = plausibility.check_deltas(nominal, far)
    assert "a2" in message and "40" in message
    absurd = nominal.copy()
    absurd[3, 3] *= 1000.0  # d4 in um
    with pytest.raises(CalibrationError, match="d4"):
        plausibility.check_deltas(nominal, absurd)


# ---------------------------------------------------------------- item 7: strict types


BASE = {"format": "calibrator.session", "version": 1, "frame": "base", "model": "er10l-c10"}


@pytest.mark.parametrize(
    ("key", "value", "match"),
    [
        ("tool_known", "false", "tool_known"),
        ("tool_known", 0, "tool_known"),
        ("tool_known", None, "tool_known"),
        ("version", True, "version"),
        ("version", 1.0, "version"),
        ("frame", ["base"], "frame"),
        ("model", 5, "model"),
        ("model", ["ur5e"], "model"),
        ("format", None, "format"),
        ("flange2tool", [["1", 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], "flange2tool"),
        ("flange2tool", [[True, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], "flange2tool"),
        ("nominal_mdh", [["170", -1.57, 0, 0, 0]] * 6, "nominal_mdh"),
        ("nominal_mdh", {"a": 1}, "nominal_mdh"),
    ],
)
def test_metadata_values_must_have_their_json_types(tmp_path, key, value, match):
    table, _ = _simulated()
    meta = dict(BASE, **{key: value})
    with pytest.raises(SessionError, match=match):
        session.load(_write(tmp_path / "s.parquet", table, meta))


def test_deeply_nested_metadata_is_one_line(tmp_path):
    table, _ = _simulated()
    raw = '{"format": "calibrator.session", "version": 1, "frame": "base", "x": ' + (
        "[" * 100_000 + "]" * 100_000 + "}"
    )
    table = table.replace_schema_metadata({b"calibrator": raw.encode()})
    pq.write_table(table, tmp_path / "s.parquet")
    with pytest.raises(SessionError, match="nested"):
        session.load(tmp_path / "s.parquet")


def test_duplicate_column_names_are_refused(tmp_path):
    table, meta = _simulated()
    dup = pa.Table.from_arrays([*table.columns, table["x_mm"]], names=[*table.column_names, "x_mm"])
    with pytest.raises(SessionError, match="x_mm.*more than once"):
        session.load(_write(tmp_path / "s.parquet", dup, meta))


@pytest.mark.parametrize(
    "column",
    [
        lambda n: pa.array([[1.0, 2.0]] * n),
        lambda n: pa.array([{"v": 1.0}] * n),
        lambda n: pa.array(["1.0"] * n),
        lambda n: pa.array([True] * n),
        lambda n: pa.array(np.ones(n, dtype=np.float16)),
    ],
    ids=["list", "struct", "string", "bool", "float16"],
)
def test_odd_column_types_in_a_required_column_are_refused(tmp_path, column):
    table, meta = _simulated()
    i = table.column_names.index("y_mm")
    table = table.set_column(i, "y_mm", column(table.num_rows))
    with pytest.raises(SessionError, match="y_mm"):
        session.load(_write(tmp_path / "s.parquet", table, meta))


def test_odd_extra_columns_are_kept_and_ignored(tmp_path):
    table, meta = _simulated()
    n = table.num_rows
    table = table.append_column("notes", pa.array([[1, 2]] * n))
    table = table.append_column("nested", pa.array([{"a": {"b": 1}}] * n))
    loaded = session.load(_write(tmp_path / "s.parquet", table, meta))
    assert "notes" in loaded.table.column_names


@pytest.mark.parametrize(
    ("column", "value"),
    [
        ("x_mm", 1e308),
        ("z_mm", -1e30),
        ("q2_rad", 2.0**62),
        ("q6_rad", -1e300),
        ("sx_mm", -0.01),  # a negative standard deviation
        ("rx_rad", 1e200),
    ],
)
def test_absurd_values_are_refused(tmp_path, column, value):
    table, meta = _simulated()
    if column not in table.column_names:
        table = table.append_column(column, pa.array(np.full(table.num_rows, 0.01)))
    values = np.asarray(table[column].to_pylist(), dtype=float)
    values[5] = value
    table = table.set_column(table.column_names.index(column), column, pa.array(values))
    with pytest.raises(SessionError, match=column):
        session.load(_write(tmp_path / "s.parquet", table, meta))


def test_joint_column_of_huge_integers_is_refused(tmp_path):
    table, meta = _simulated()
    i = table.column_names.index("q1_rad")
    table = table.set_column(i, "q1_rad", pa.array(np.full(table.num_rows, 2**62, np.int64)))
    with pytest.raises(SessionError, match="q1_rad"):
        session.load(_write(tmp_path / "s.parquet", table, meta))


def test_huge_pose_numbers_stay_exact(tmp_path):
    table, meta = _simulated()
    poses = pa.array(2**62 + np.arange(table.num_rows, dtype=np.int64))
    table = table.set_column(table.column_names.index("pose"), "pose", poses)
    loaded = session.load(_write(tmp_path / "s.parquet", table, meta))
    assert loaded.table.num_rows == table.num_rows


def test_identical_poses_are_refused(tmp_path):
    table, meta = _simulated()
    for name in JOINTS + POINTS:
        value = table[name][0].as_py()
        i = table.column_names.index(name)
        table = table.set_column(i, name, pa.array([value] * table.num_rows))
    with pytest.raises(SessionError, match="same"):
        session.load(_write(tmp_path / "s.parquet", table, meta))


def test_cli_identify_gives_one_line_and_exit_2_for_a_bad_session(tmp_path):
    table, meta = _simulated()
    path = _write(tmp_path / "s.parquet", _scaled(table, POINTS, 1e-3), dict(meta))
    result = run_cli("identify", path, "-o", tmp_path / "c.json")
    assert result.returncode == 2
    assert "Traceback" not in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1 and "metres" in result.stderr
    assert not (tmp_path / "c.json").exists()


def test_a_custom_arm_named_only_by_its_nominal_table_loads(tmp_path):
    table, meta = _simulated()
    meta["model"] = "my-custom-arm"  # unknown name; nominal_mdh describes the arm
    loaded = session.load(_write(tmp_path / "s.parquet", table, meta))
    assert loaded.meta.model == "my-custom-arm" and loaded.warnings == []


def test_a_scale_off_by_less_than_a_unit_is_a_warning(tmp_path):
    table, meta = _simulated()
    path = _write(tmp_path / "s.parquet", _scaled(table, POINTS, 2.0), meta)
    (warning,) = session.load(path).warnings
    assert "do not fit the model" in warning
