"""The check's measured points, their standard errors and the run's measuring conditions.

An averaged point's standard error is its readings' spread over the root of
their number: a pose read once keeps its spread, read four times half of it;
a record that does not say how many readings it took counts as one. Only
the measured poses count, in pose order. The conditions
(calibrator/check/procedure.py) span the first to the last time stamp of the
measured poses, none when no pose has one, with the readings' spread. A
noise the calibration estimated from few rows is judged by the F
distribution, an exact one by chi-square (calibrator/check/verdict.py).
"""

from __future__ import annotations

import numpy as np
import pytest

from calibrator.check import document, procedure
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


def test_the_measuring_conditions_span_the_stamped_readings_and_their_spread():
    records = {
        "a": {**_record(1, n=4), "timestamp": "2026-12-06T10:00:05+00:00"},
        "b": {**_record(2, n=4), "timestamp": "2026-12-06T10:00:01+00:00"},
        "c": {**_record(3, n=4), "std_mm": [0.3, 0.4, 0.0]},  # no time stamp
        "d": {**_record(4, status="failed"), "timestamp": "2026-12-06T09:00:00+00:00"},
    }
    conditions = procedure.measuring_conditions(records)
    assert conditions["started"] == "2026-12-06T10:00:01+00:00"
    assert conditions["ended"] == "2026-12-06T10:00:05+00:00"
    one = float(np.linalg.norm([0.02, 0.04, 0.06]))
    assert conditions["reading_spread_mm"] == pytest.approx(
        {"mean": (2 * one + 0.5) / 3, "max": 0.5}
    )
    # A journal without time stamps (an older version's) has no span, and says so.
    bare = {k: v for k, v in records.items() if k in ("c", "d")}
    bare["e"] = _record(5, n=2)
    conditions = procedure.measuring_conditions(bare)
    assert conditions["started"] is None and conditions["ended"] is None


def test_a_noise_estimated_from_few_rows_is_judged_by_the_f_distribution():
    """A calibration's noise from 12 residual degrees of freedom: the check's p-value is F's."""
    from scipy import stats

    from calibrator import robots
    from calibrator.check.model import Calibrated
    from calibrator.model import joint_terms, parameters

    arm = robots.get("ur10e")
    # One free parameter, known exactly (zero covariance): the noise alone is judged.
    space = parameters.ParameterSpace(arm.mdh, np.eye(4), np.eye(4), ("theta2",))
    terms = joint_terms.JointTerms(np.zeros(6), np.zeros(6), np.zeros(6), np.zeros(6))
    zero = np.zeros((space.size, space.size))
    q = np.random.default_rng(5).uniform(-1.5, 1.5, (6, 6))
    few, exact = Calibrated(space, zero, 0.05, terms, 12), Calibrated(space, zero, 0.05, terms)
    errors = np.random.default_rng(6).normal(0.0, 0.08, (6, 3))
    points = few.points(q) + errors
    judged = document.evaluate(few, q, points, None)["verdict"]
    statistic = float((errors**2).sum() / 0.05**2)
    assert judged.p_value == pytest.approx(stats.f.sf(statistic / 18, 18, 12), rel=1e-9)
    # The same errors judged against an exactly known noise: chi-square's, far smaller.
    assert document.evaluate(exact, q, points, None)["verdict"].p_value == pytest.approx(
        stats.chi2.sf(statistic, 18), rel=1e-9
    )
