"""Property tests of session loading: any file gives a Session or one SessionError line.

Hypothesis builds Parquet files with random column sets, types and values
(NaN, infinities, huge numbers, nulls, nested types, duplicate names) and
random metadata (any JSON, wrong types for known keys, non-JSON bytes).
``session.load`` must return a :class:`Session` or raise :class:`SessionError`
with a one-line message: never another exception.
"""

import json
import math
import tempfile
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from calibrator import session
from calibrator.errors import SessionError
from calibrator.simulate import simulate

REQUIRED = ("pose", *session.JOINT_COLUMNS, *session.POINT_COLUMNS)
OPTIONAL = (*session.ROTVEC_COLUMNS, *session.SPREAD_COLUMNS, "n_readings", "q7_rad", "timestamp")

floats = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(-4.0, 4.0),
    st.floats(-3000.0, 3000.0),
    st.sampled_from([0.0, 1e308, -1e308, 2.0**62, 1e-320]),
)


@st.composite
def column(draw, n):
    kind = draw(
        st.sampled_from(
            ["f64", "f32", "f16", "i64", "i8", "u64", "bool", "str", "list", "struct", "null"]
        )
    )
    if kind == "f64":
        return pa.array(draw(st.lists(floats, min_size=n, max_size=n)), pa.float64())
    if kind == "f32":
        values = draw(st.lists(st.floats(-1e6, 1e6, width=32), min_size=n, max_size=n))
        return pa.array(values, pa.float32())
    if kind == "f16":
        values = draw(st.lists(st.floats(-10, 10), min_size=n, max_size=n))
        return pa.array(np.asarray(values, np.float16))
    if kind in ("i64", "i8", "u64"):
        lo, hi, typ = {
            "i64": (-(2**63), 2**63 - 1, pa.int64()),
            "i8": (-128, 127, pa.int8()),
            "u64": (0, 2**64 - 1, pa.uint64()),
        }[kind]
        return pa.array(draw(st.lists(st.integers(lo, hi), min_size=n, max_size=n)), typ)
    if kind == "bool":
        return pa.array(draw(st.lists(st.booleans(), min_size=n, max_size=n)))
    if kind == "str":
        return pa.array(draw(st.lists(st.text(max_size=5), min_size=n, max_size=n)))
    if kind == "list":
        return pa.array(draw(st.lists(st.lists(floats, max_size=3), min_size=n, max_size=n)))
    if kind == "struct":
        return pa.array([{"v": draw(floats)} for _ in range(n)])
    return pa.nulls(n)


json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=8),
    lambda children: (
        st.lists(children, max_size=4) | st.dictionaries(st.text(max_size=6), children, max_size=4)
    ),
    max_leaves=20,
)
known_keys = st.sampled_from(
    ["format", "version", "frame", "model", "nominal_mdh", "flange2tool", "tool_known"]
)
GOOD_META = {"format": "calibrator.session", "version": 1, "frame": "base", "model": "ur5e"}


@st.composite
def metadata(draw):
    choice = draw(st.integers(0, 4))
    if choice == 0:
        return None
    if choice == 1:
        return draw(st.binary(max_size=40))
    meta = dict(GOOD_META)
    for key in draw(st.lists(known_keys, max_size=3)):
        meta[key] = draw(json_values)
    if choice == 3:
        meta.update(draw(st.dictionaries(st.text(max_size=6), json_values, max_size=3)))
    if choice == 4:
        meta["nominal_mdh"] = draw(
            st.lists(st.lists(st.one_of(floats, st.booleans()), min_size=5, max_size=5), max_size=7)
        )
    return json.dumps(meta).encode()


@st.composite
def session_files(draw):
    n = draw(st.integers(0, 8))
    names = [c for c in REQUIRED if draw(st.integers(0, 15))]  # usually all present
    names += draw(st.lists(st.sampled_from(OPTIONAL + REQUIRED), max_size=3))
    arrays = [draw(column(n)) for _ in names]
    return names, arrays, draw(metadata())


def _load_written(names, arrays, meta):
    table = pa.Table.from_arrays(arrays, names=names) if names else pa.table({})
    if meta is not None:
        table = table.replace_schema_metadata({b"calibrator": meta})
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "s.parquet"
        pq.write_table(table, path)
        return session.load(path)


def _assert_clean(names, arrays, meta):
    try:
        loaded = _load_written(names, arrays, meta)
    except SessionError as exc:
        message = str(exc)
        assert message and "\n" not in message
        return None
    # Whatever loaded is plausible: finite, inside the magnitude bounds.
    q = loaded.array(session.JOINT_COLUMNS)
    points = loaded.array(session.POINT_COLUMNS)
    assert np.all(np.isfinite(q)) and np.all(np.isfinite(points))
    assert np.all(np.abs(q) <= 2 * math.pi + 1e-6)
    assert isinstance(loaded.meta.tool_known, bool)
    return loaded


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(session_files())
def test_any_file_loads_or_gives_one_session_error(files):
    _assert_clean(*files)


_TABLE, _META, _ = simulate(model="ur5e", poses=12, seed=5, errors="random")
_META_JSON = json.dumps(_META.to_json()).encode()


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    st.sampled_from(REQUIRED + session.ROTVEC_COLUMNS),
    st.integers(0, 11),
    floats,
)
def test_one_bad_value_in_a_plausible_session_is_refused_or_harmless(name, row, value):
    values = _TABLE[name].to_pylist()
    values[row] = value
    i = _TABLE.column_names.index(name)
    table = _TABLE.set_column(i, name, pa.array(values, pa.float64()))
    loaded = _assert_clean(table.column_names, table.columns, _META_JSON)
    if loaded is not None and name in session.POINT_COLUMNS:
        assert abs(value) < 1e4  # ur5e: no point can be 10 m from the others
    if loaded is not None and name in session.JOINT_COLUMNS:
        assert abs(value) <= 2 * math.pi


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(known_keys, json_values)
def test_any_json_value_for_a_known_key_is_typed_or_refused(key, value):
    meta = _META.to_json()
    meta[key] = value
    loaded = _assert_clean(_TABLE.column_names, _TABLE.columns, json.dumps(meta).encode())
    if loaded is not None and key == "tool_known":
        assert value is True or value is False
