"""Edges the history's records and limits must get right: a check document's every
refusal, a figure exactly at its limit, a timeout at the ends of its range, the robot
a calibration is recorded for. Pure functions and real SQLite files.

Found by hand-written slips (issue 44's K2 method: a threshold ``>`` made ``>=``,
a variable forgotten in a test of two, a range end moved, an argument forgotten).
"""

from __future__ import annotations

import shutil
from datetime import datetime, timedelta

import pytest
from history_kit import check_doc

from calibrator.history import HistoryError, alarms, open_history, records


@pytest.mark.parametrize(
    "change, message",
    [
        ({"measured_mm": -0.01}, "'measured_mm' and 'predicted_mm' must be >= 0"),
        ({"predicted_mm": -0.01}, "'measured_mm' and 'predicted_mm' must be >= 0"),
        ({"explanation": "joint 2"}, "'explanation' must be what explains a change"),
        ({"pose_errors_mm": "0.1"}, "'pose_errors_mm' must be"),
        ({"pose_errors_mm": [True]}, "'pose_errors_mm' must be"),
        ({"calibration_sha256": "AB" * 32}, "'calibration_sha256' must be the SHA-256"),
        ({"extra": float("nan")}, "check: not plain JSON"),
    ],
)
def test_a_check_document_is_refused_naming_what_is_wrong(change, message):
    with pytest.raises(HistoryError, match=message):
        records.check(check_doc() | change)


def test_a_check_missing_several_fields_names_the_first_and_counts_the_rest():
    doc = {k: v for k, v in check_doc().items() if k not in ("verdict", "explanation", "time")}
    with pytest.raises(HistoryError) as caught:
        records.check(doc, "c.json")
    assert str(caught.value) == (
        "c.json: missing 'time': when it was measured (ISO 8601) (and 2 more)"
    )
    with pytest.raises(HistoryError, match="^check: a check must be a JSON object$"):
        records.check([check_doc()])


def test_a_check_is_filed_when_its_poses_were_measured_and_keeps_its_tracker():
    doc = check_doc(robot="  arm-1 ") | {
        "measured_at": "2026-03-01T10:00:00+01:00",
        "tracker": "leica:AT960:7",
        "pose_errors_mm": [0.05, 1],
    }
    record = records.check(doc)
    assert record.row["time"] == datetime(2026, 3, 1, 9, 0)
    assert (record.robot, record.tracker) == ("arm-1", "leica:AT960:7")
    assert record.row["pose_errors_mm"] == [0.05, 1.0]
    assert record.row["document"] == doc
    assert record.row["sha256"] == records.document_sha256(doc)
    # The same document, keys in another order: the same record.
    assert records.check(dict(reversed(list(doc.items())))).row["sha256"] == record.row["sha256"]


def test_a_figure_exactly_at_its_limit_is_not_above_it():
    times = [datetime(2026, 1, 1) + timedelta(days=30 * m) for m in range(2)]
    assert alarms.crossing("AP", times, [0.1, 0.2], limit=0.2) == []
    (alarm,) = alarms.crossing("AP", times, [0.1, 0.2000001], limit=0.2)
    assert alarm.kind == "limit"


@pytest.mark.parametrize("seconds, accepted", [("0.5", True), ("3600", True), ("0.49", False),
                                               ("3600.5", False), ("nan", False)])  # fmt: skip
def test_a_timeout_is_taken_at_the_ends_of_its_range(tmp_path, seconds, accepted):
    url = f"sqlite:///{tmp_path / 'h.sqlite'}?timeout={seconds}"
    if accepted:
        with open_history(url) as h:
            assert h.engine.history_timeout_s == float(seconds)
    else:
        with pytest.raises(HistoryError, match=r"is not a number of seconds in \[0.5, 3600\]"):
            open_history(url)
        assert not (tmp_path / "h.sqlite").exists()


def test_a_calibration_recorded_for_a_robot_files_its_session_under_it(measured, tmp_path):
    for name in ("s0.parquet", "cal0.json"):
        shutil.copy(measured / name, tmp_path / name)
    with open_history(tmp_path / "h.sqlite") as h:
        h.record_calibration(tmp_path / "cal0.json", robot="cell-3 arm")
        assert [r["name"] for r in h.robots()] == ["cell-3 arm"]
        (session,) = h.sessions("cell-3 arm")
        (calibration,) = h.calibrations("cell-3 arm")
    assert calibration["session_id"] == session["id"]
