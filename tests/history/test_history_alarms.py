"""The alarm logic: pure functions of a robot's records."""

from datetime import datetime, timedelta

import numpy as np
import pytest
from scipy import stats

from calibrator.history import alarms

T0 = datetime(2026, 1, 1)


def _month(m):
    return T0 + timedelta(days=30 * m)


def _cal(m, params, se=None, held_out=0.05):
    return {
        "created": _month(m),
        "parameters": dict(params),
        "uncertainties": dict(dict.fromkeys(params, 1e-4) if se is None else se),
        "held_out_rms_mm": held_out,
    }


def _monthly_with_crash():
    """12 monthly calibrations: every parameter wears slowly, joint 2's zero jumps in month 8."""
    rng = np.random.default_rng(5)
    cals = []
    for m in range(1, 13):
        params = {
            "theta2": 1e-5 * m + (4e-4 if m >= 8 else 0.0),  # rad: 0.4 mrad crash
            "a3": 0.002 * m,  # mm: slow wear, 0.002 mm a month
            "d4": float(rng.normal(0, 5e-4)),  # mm: noise only
        }
        se = {"theta2": 3e-5, "a3": 1e-3, "d4": 5e-4}
        cals.append(_cal(m, params, se, held_out=0.05 + 0.001 * m))
    return cals


def test_crash_in_month_8_is_the_only_alarm_and_names_the_joint():
    found = alarms.alarms(_monthly_with_crash())
    assert [(a.time, a.kind, a.subject) for a in found] == [(_month(8), "moved", "theta2")]
    assert found[0].message.startswith("joint 2 zero (theta2) moved +0.41 mrad ± 0.0424 mrad")
    assert "(9.7 standard errors; the two calibrations differ by chi2 95.4 on 3" in found[0].message
    assert (found[0].figure, found[0].unit) == (pytest.approx(95.4, abs=0.05), "chi2")
    assert found[0].threshold == pytest.approx(stats.chi2.isf(1e-3, 3))
    assert found[0].change == pytest.approx(4.1e-4) and found[0].change_unit == "rad"


def test_a_move_is_judged_against_the_chi_square_quantile_of_the_pair():
    se = {"a1": 0.01}
    # One parameter: alarm beyond the 1e-3 quantile of chi2(1), 3.29 standard errors.
    edge = 0.01 * np.sqrt(2) * np.sqrt(stats.chi2.isf(1e-3, 1))
    just_under = [_cal(0, {"a1": 0.0}, se), _cal(1, {"a1": 0.999 * edge}, se)]
    just_over = [_cal(0, {"a1": 0.0}, se), _cal(1, {"a1": -1.001 * edge}, se)]
    assert alarms.moved(just_under) == []
    (alarm,) = alarms.moved(just_over)
    assert alarm.subject == "a1" and "moved -0.0466 mm" in alarm.message
    # No standard error on one side: not judged.
    assert alarms.moved([_cal(0, {"a1": 0.0}, {}), _cal(1, {"a1": 5.0}, se)]) == []


def test_correlations_decide_what_moved():
    """Two parameters that trade off (correlation -0.99): moving together along their
    valley is noise; a change across it is an alarm naming the one that explains it."""
    from calibrator.history import compare

    se = np.array([0.01, 0.01])
    cov = np.outer(se, se) * np.array([[1.0, -0.99], [-0.99, 1.0]])

    def state(values):
        return compare.State(("a2", "a3"), np.array(values, float), cov)

    # +0.02 / -0.02 mm: 1.4 standard errors each on its own, and along the valley.
    assert not compare.compare(state([0, 0]), state([0.02, -0.02])).moved
    # +0.01 on a2 alone: a small change each on its own, but across the valley.
    found = compare.compare(state([0, 0]), state([0.01, 0.0]))
    assert found.moved and [c.name for c in found.changes] == ["a2"]
    assert found.changes[0].change == pytest.approx(0.01)


def test_tool_and_base_are_compared_only_when_the_sessions_allow_it():
    from calibrator.history import compare

    names = ("a2", "base_tx", "base_ty", "base_tz", "base_rx", "base_ry", "base_rz", "tool_x")
    cov = np.eye(len(names)) * 1e-6

    def state(tool_x, tool=None, world=None, base_x=0.0):
        base = np.eye(4)
        base[0, 3] = base_x
        return compare.State(
            names, np.array([0, 0, 0, 0, 0, 0, 0, tool_x]), cov, tool, world,
            None if world is None else base,
        )  # fmt: skip

    # A tool 0.3 mm off: no tool declared, or two tools: not compared, and said so.
    plain = compare.compare(state(0.0), state(0.3))
    assert not plain.moved and plain.compared == ("a2",)
    assert plain.not_compared[0].startswith("tool not compared: the sessions declare no tool")
    other = compare.compare(state(0.0, "smr-A"), state(0.3, "smr-B"))
    assert not other.moved and "another tool (smr-A then smr-B)" in other.not_compared[0]
    # The same tool: it moved.
    same = compare.compare(state(0.0, "smr-A"), state(0.3, "smr-A"))
    assert [c.name for c in same.changes] == ["tool_x"]
    # The base 0.2 mm off in one world frame: it moved; in none: not compared.
    moved = compare.compare(state(0, world="cell"), state(0, world="cell", base_x=0.2))
    assert [c.name for c in moved.changes] == ["base_tx"]
    assert not compare.compare(state(0), state(0, base_x=0.2)).moved


def test_limit_and_trend():
    times = [_month(m) for m in range(6)]
    # Above the limit: one alarm per point above.
    found = alarms.crossing("AP", times, [0.1, 0.1, 0.25, 0.1, 0.1, 0.1], limit=0.2)
    assert [(a.kind, a.time) for a in found] == [("limit", _month(2))]
    # A steady rise of 0.02 mm a month from 0.1 mm reaches 0.3 mm 10 months after
    # the start: seen from month 5, in 5 months (150 days): beyond a 90-day horizon...
    rising = [0.1 + 0.02 * m for m in range(6)]
    assert alarms.crossing("AP", times, rising, limit=0.3) == []
    # ...within a 185-day one, and the message says when; from month 4 (with 4
    # points: months 1-4) it was 180 days away: each point is judged as the
    # history looked that day; from month 3 it was 210 days away.
    found = alarms.crossing("AP", times, rising, limit=0.3, horizon=timedelta(days=185))
    assert [(a.kind, a.time) for a in found] == [("trend", _month(4)), ("trend", _month(5))]
    assert "reaches its limit 0.300 mm in about 150 days" in found[1].message
    assert found[1].threshold == 0.3
    assert found[1].figure == pytest.approx(0.2 + 0.02 * 185 / 30)
    # Falling or flat: no trend alarm; too few points: none.
    assert alarms.crossing("AP", times, rising[::-1], limit=0.3, horizon=timedelta(days=999)) == []
    assert alarms.crossing("AP", times[:3], rising[:3], 0.15, timedelta(days=999)) == []
    # Default limit: twice the first value.
    (over,) = alarms.crossing("RP", times[:2], [0.01, 0.021], None)
    assert "above its limit 0.020 mm" in over.message


def test_checks_not_ok_raise_an_alarm_with_their_explanation():
    checks = [
        {"time": _month(1), "verdict": "ok", "measured_mm": 0.05, "predicted_mm": 0.05,
         "explanation": []},
        {"time": _month(2), "verdict": "recalibrate", "measured_mm": 0.4, "predicted_mm": 0.05,
         "explanation": [{"text": "joint 2 zero moved 0.41 ± 0.03 mrad"}]},
    ]  # fmt: skip
    (alarm,) = alarms.alarms([], checks=checks)
    assert alarm.kind == "check" and alarm.time == _month(2)
    assert alarm.message.endswith("joint 2 zero moved 0.41 ± 0.03 mrad")


def test_compensated_tests_are_the_series_when_there_are_some():
    tests = [
        {"measured_at": _month(m), "compensated": c, "ap_mm": ap, "rp_mm": 0.01}
        for m, c, ap in ((0, False, 3.0), (0, True, 0.1), (1, True, 0.11), (2, False, 3.1))
    ]
    assert alarms.alarms([], tests) == []  # nominal AP of 3 mm is not a calibration's drift
    tests.append({"measured_at": _month(3), "compensated": True, "ap_mm": 0.5, "rp_mm": 0.01})
    (alarm,) = alarms.alarms([], tests)
    assert (alarm.subject, alarm.kind, alarm.time) == ("AP", "limit", _month(3))
