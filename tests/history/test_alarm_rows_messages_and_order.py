"""The alarms as ``history alarms`` hands them on: rows, CSV, messages, names and order.

Pure functions of records (no database). Found by mutation testing (issue
44): the alarm tests read the alarms' kinds and times, not the rows
``--csv``/``--json`` write, a check alarm's whole sentence, the records an
alarm names or the order of alarms at one time.
"""

from __future__ import annotations

import csv
import io
from datetime import datetime, timedelta

import pytest

from calibrator.history import alarms

T0 = datetime(2026, 1, 1)


def _month(m: int) -> datetime:
    return T0 + timedelta(days=30 * m)


def _cal(number, m, value, held_out=0.05):
    return {
        "id": number,
        "time": _month(m),
        "created": _month(m) + timedelta(days=1),
        "parameters": {"a1": value},
        "uncertainties": {"a1": 0.01},
        "held_out_rms_mm": held_out,
    }


def _check(number, m, verdict, document=None):
    return {
        "id": number,
        "time": _month(m),
        "verdict": verdict,
        "measured_mm": 0.4,
        "predicted_mm": 0.05,
        "explanation": [{"text": "joint 2 zero moved"}],
        "document": document or {},
    }


def test_a_moved_alarm_names_both_calibrations_and_its_figures():
    (alarm,) = alarms.moved([_cal(3, 0, 0.0), _cal(9, 1, 0.2)])
    assert alarm.records == ("calibration 3", "calibration 9")
    assert alarm.time == _month(1)
    assert alarm.change == pytest.approx(0.2) and alarm.change_unit == "mm"
    assert alarm.standard_error == pytest.approx(0.01 * 2**0.5)
    assert "(14.1 standard errors;" in alarm.message
    assert f"since {_month(0):%Y-%m-%d %H:%M:%S}" in alarm.message
    # Rows without ids (not from a history) are named by their kind only.
    rows = [{k: v for k, v in c.items() if k != "id"} for c in (_cal(3, 0, 0.0), _cal(9, 1, 0.2))]
    assert alarms.moved(rows)[0].records == ("calibration", "calibration")


def test_a_calibration_without_its_session_time_is_dated_when_it_was_made():
    before, after = _cal(1, 0, 0.0), _cal(2, 1, 0.2)
    del after["time"]
    (alarm,) = alarms.moved([before, after])
    assert alarm.time == _month(1) + timedelta(days=1)


def test_a_check_alarm_says_the_figures_and_why_and_carries_its_p_value():
    (alarm,) = alarms.check_verdicts(
        [_check(4, 1, "ok"), _check(5, 2, "drifted", {"p_value": 2e-5, "alarm_p": 0.01})]
    )
    assert (alarm.kind, alarm.subject, alarm.records) == ("check", "drifted", ("check 5",))
    assert alarm.message == (
        "drifted: measured 0.400 mm against 0.050 mm predicted; joint 2 zero moved"
    )
    assert (alarm.figure, alarm.threshold, alarm.unit) == (2e-5, 0.01, "p (below)")
    # No p-value recorded: no figure, the default alarm probability.
    bare = _check(6, 3, "recalibrate") | {"explanation": []}
    (alarm,) = alarms.check_verdicts([bare])
    assert alarm.figure is None and alarm.threshold == 1e-3
    assert alarm.message.endswith("predicted; no explanation recorded")


def test_alarms_at_one_time_are_ordered_by_kind_then_subject():
    cals = [_cal(1, 0, 0.0, held_out=0.05), _cal(2, 1, 0.2, held_out=0.2)]
    tests = [
        {"id": 7, "measured_at": _month(1), "compensated": True, "ap_mm": 0.1, "rp_mm": 0.01},
        {"id": 8, "measured_at": _month(2), "compensated": True, "ap_mm": 0.3, "rp_mm": 0.03},
    ]
    checks = [_check(5, 1, "recalibrate")]
    found = alarms.alarms(cals, tests, checks)
    assert [(a.time, a.kind, a.subject) for a in found] == [
        (_month(1), "check", "recalibrate"),
        (_month(1), "limit", "held-out error"),
        (_month(1), "moved", "a1"),
        (_month(2), "limit", "AP"),
        (_month(2), "limit", "RP"),
    ]
    assert found[1].records == ("calibration 2",)
    assert found[3].records == ("iso9283 8",)


def test_rows_and_csv_hold_every_column_of_each_alarm():
    (alarm,) = alarms.moved([_cal(3, 0, 0.0), _cal(9, 1, 0.2)])
    (row,) = alarms.as_rows([alarm], robot="arm-1")
    assert list(row) == ["robot", *alarms.ALARM_COLUMNS]
    assert row["robot"] == "arm-1"
    assert row["time"] == "2026-01-31T00:00:00Z"
    assert (row["kind"], row["subject"], row["unit"]) == ("moved", "a1", "chi2")
    assert row["records"] == "calibration 3; calibration 9"
    assert row["figure"] == alarm.figure and row["threshold"] == alarm.threshold
    assert (row["change"], row["standard_error"]) == (alarm.change, alarm.standard_error)
    assert row["change_unit"] == "mm" and row["message"] == alarm.message
    (plain,) = alarms.as_rows([alarm])
    assert list(plain) == list(alarms.ALARM_COLUMNS)

    (limit,) = alarms.crossing("AP", [_month(0), _month(1)], [0.1, 0.3], 0.2)
    read = list(csv.DictReader(io.StringIO(alarms.csv_text(alarms.as_rows([alarm, limit], "r")))))
    assert [r["kind"] for r in read] == ["moved", "limit"]
    assert read[1]["change"] == "" and read[1]["change_unit"] == ""  # absent: empty cells
    assert read[1]["figure"] == "0.3" and read[1]["threshold"] == "0.2"
    assert read[0]["change_unit"] == "mm" and read[0]["robot"] == "r"
    # No alarms: the header alone.
    assert alarms.csv_text([]) == ",".join(["robot", *alarms.ALARM_COLUMNS]) + "\n"


def test_what_was_not_compared_is_said_once_per_reason_with_the_pairs():
    tool = {"names": ["a1", "tool_x"], "values": [0.0, 0.0], "covariance": [[1e-4, 0], [0, 1e-4]]}

    def cal(number, tool_id=None):
        setup = {"tool_id": tool_id} if tool_id else {}
        return {"id": number, "time": _month(number), "statistics": {"arm": tool, "setup": setup}}

    three = [cal(1), cal(2), cal(3)]
    said = alarms.not_compared(three)
    assert said == [
        "tool not compared: the sessions declare no tool (tool_id) "
        "(every two consecutive calibrations)",
        "base not compared: the tracker's pose is not recorded in one world frame in both "
        "sessions (tracker_pose) (every two consecutive calibrations)",
    ]
    # One pair of two not compared on the tool: that pair named.
    mixed = [cal(1, "smr"), cal(2, "smr"), cal(3)]
    assert alarms.not_compared(mixed)[1] == (
        "tool not compared: the sessions declare no tool (tool_id) "
        "(calibration 2 and calibration 3)"
    )
    # A single pair is named, not called "every".
    assert alarms.not_compared(three[:2])[0].endswith("(calibration 1 and calibration 2)")


def test_a_trend_alarm_names_its_points_and_the_rise_a_month():
    times = [_month(m) for m in range(4)]
    rising = [0.1, 0.12, 0.14, 0.16]
    (alarm,) = alarms.crossing(
        "AP", times, rising, limit=0.2, horizon=timedelta(days=90), records=["a", "b", "c", "d"]
    )
    assert alarm.kind == "trend" and alarm.records == ("a", "b", "c", "d")
    assert "rises 0.020 mm a month over the last 4 points" in alarm.message
    # 0.16 mm at month 3, 0.02 mm a month: 0.2 mm 60 days later.
    assert "reaches its limit 0.200 mm in about 60 days" in alarm.message
    assert alarm.figure == pytest.approx(0.16 + 0.02 * 3)


def test_a_trend_seen_from_points_at_one_time_is_no_trend():
    same = [_month(1)] * 4
    assert alarms.crossing("AP", same, [0.1, 0.12, 0.14, 0.16], 0.2, timedelta(days=900)) == []


def test_explanation_items_without_text_are_their_message_or_themselves():
    assert alarms.explanation_text({"message": "re-master J2"}) == "re-master J2"
    assert alarms.explanation_text({"cause": "x"}) == "{'cause': 'x'}"
    assert alarms.explanation_text("plain") == "plain"
    # Sentences that are not all text: the items are used.
    check = {"document": {"explanation_text": ["a", 3]}, "explanation": ["b"]}
    assert alarms.explanations(check) == ["b"]
    assert alarms.explanations({"document": None, "explanation": ["c"]}) == ["c"]


@pytest.mark.parametrize(
    "name, words",
    [
        ("theta2", "joint 2 zero (theta2)"),
        ("a3", "joint 3 link length a (a3)"),
        ("alpha1", "joint 1 link twist alpha (alpha1)"),
        ("d6", "joint 6 link offset d (d6)"),
        ("beta2", "joint 2 twist beta (beta2)"),
        ("tool_x", "tool_x"),
        ("theta7", "theta7"),
    ],
)
def test_parameters_are_described_in_words(name, words):
    assert alarms.describe(name) == words
