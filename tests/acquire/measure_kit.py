"""Helpers for the measure tests: run the CLI as a user does, read sessions back."""

import numpy as np
import pyarrow.parquet as pq


def session_rows(path):
    """A session file's rows as {pose: (q, point)} (exact floats)."""
    table = pq.read_table(path).to_pydict()
    q = np.column_stack([table[f"q{i}_rad"] for i in range(1, 7)])
    p = np.column_stack([table[c] for c in ("x_mm", "y_mm", "z_mm")])
    return {int(n): (q[i], p[i]) for i, n in enumerate(table["pose"])}


def assert_same_session(a, b, readings=10):
    """Two sessions hold the same poses, pose for pose, bit for bit, each a full average."""
    for path in (a, b):
        assert set(pq.read_table(path, columns=["n_readings"])["n_readings"].to_pylist()) == {
            readings
        }
    rows_a, rows_b = session_rows(a), session_rows(b)
    assert sorted(rows_a) == sorted(rows_b)
    for pose in rows_a:
        np.testing.assert_array_equal(rows_a[pose][0], rows_b[pose][0], err_msg=f"pose {pose}")
        np.testing.assert_array_equal(rows_a[pose][1], rows_b[pose][1], err_msg=f"pose {pose}")
