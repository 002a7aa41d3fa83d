"""The check's measured points and their standard errors (calibrator/check/document.py).

An averaged point's standard error is its readings' spread over the root of
their number: a pose read once keeps its spread, read four times half of it;
a record that does not say how many readings it took counts as one. Only
the measured poses count, in pose order.
"""

from __future__ import annotations

import numpy as np
import pytest

from calibrator.check import document
from calibrator.errors import CalibrationError


def _record(pose, n=None, status="measured"):
    out = {
        "status": status,
        "pose": pose,
        "q_rad": [0.1 * pose] * 6,
        "point_mm": [1000.0 + pose, 2.0, 3.0],
        "std_mm": [0.02, 0.04, 0.06],
    }
    if n is not None:
        out["n_readings"] = n
    return out


def test_a_points_standard_error_is_its_spread_over_the_root_of_its_readings():
    records = {
        "c": _record(7, n=4),
        "a": _record(2, n=1),
        "b": _record(5),  # an older journal: no count, one reading
        "d": _record(3, n=9, status="failed"),
    }
    poses, q, points, stderr = document.measured(records)
    assert poses == [2, 5, 7]
    np.testing.assert_allclose(points[:, 0], [1002.0, 1005.0, 1007.0])
    np.testing.assert_allclose(q[:, 0], [0.2, 0.5, 0.7])
    spread = np.array([0.02, 0.04, 0.06])
    np.testing.assert_allclose(stderr, [spread, spread, spread / 2.0])


def test_a_check_of_one_measured_pose_is_refused():
    with pytest.raises(CalibrationError, match="1 check pose"):
        document.measured({"a": _record(1, n=3), "b": _record(2, status="failed")})
