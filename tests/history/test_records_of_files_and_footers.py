"""What the history keeps of each file: the rows the records make, read against the files.

Real files made by the commands (the session-scoped ``measured`` folder:
simulate, identify, verify), and sessions whose footers say more (who
measured them with which tracker, the tool, the tracker's pose in a world
frame, a time, condition columns), written by :func:`calibrator.session.write`.
Each record is compared with the figure the file holds. Path tests get a
fast case of their own here (the path tests' fixture runs ``verify --path``,
a minute). Found by mutation testing (issue 44).
"""

from __future__ import annotations

import json
import os
from dataclasses import replace
from datetime import UTC, datetime

import numpy as np
import pyarrow as pa
import pytest

from calibrator import session as sessions
from calibrator.history import HistoryError, open_history, records

TRACKER2WORLD = [[1, 0, 0, 100.0], [0, 1, 0, -50.0], [0, 0, 1, 20.0], [0, 0, 0, 1]]


def _rewrite(source, target, extra=None, columns=None):
    """``source`` session written to ``target`` with its footer's ``extra`` replaced and
    ``columns`` ({name: values per pose}) added."""
    loaded = sessions.load(source)
    table = loaded.table
    for name, values in (columns or {}).items():
        table = table.append_column(name, pa.array(values))
    meta = replace(loaded.meta, extra=loaded.meta.extra if extra is None else extra)
    sessions.write(target, table, meta)
    return target


def test_a_verify_record_holds_the_largest_ap_and_rp_and_the_document(measured):
    path = measured / "verify.json"
    doc = json.loads(path.read_text())
    record = records.verification(path)
    assert record.row["ap_mm"] == max(p["AP_mm"] for p in doc["poses"])
    assert record.row["rp_mm"] == max(p["RP_mm"] for p in doc["poses"])
    assert record.row["compensated"] is False
    assert record.row["document"] == doc
    assert (record.robot, record.tracker, record.model) == (
        doc["robot"],
        doc["tracker"],
        doc["model"],
    )
    assert not records.is_path_record(record)
    # verify.json records no time: the file's.
    assert record.row["measured_at"] == records.file_time(path)


def test_a_verify_document_with_its_time_is_filed_at_it(measured, tmp_path):
    doc = json.loads((measured / "verify.json").read_text())
    doc |= {"time": "2026-05-04T10:00:00+02:00", "compensated": True, "model": 7}
    path = tmp_path / "v.json"
    path.write_text(json.dumps(doc))
    record = records.verification(path)
    assert record.row["measured_at"] == datetime(2026, 5, 4, 8, 0, 0)
    assert record.row["compensated"] is True
    assert record.model is None  # a model that is not a name is not one


def _path_doc(**path):
    section = {
        "shape": "line",
        "speed_mm_s": 400.0,
        "AT_P_mm": 0.8,
        "RT_P_mm": 0.05,
        "AV_pct": 2.5,
        "RV_pct": 0.7,
        "FV_mm_s": 3.0,
        "compensated": True,
    } | path
    return {
        "format": "calibrator.verify",
        "test": "path",
        "robot": "arm-7",
        "tracker": "leica:AT960:7",
        "model": "ur10e",
        "time": "2026-02-03T04:05:06Z",
        "path": section,
    }


def test_a_path_test_is_a_row_of_its_own_table_with_its_figures(tmp_path):
    path = tmp_path / "line.json"
    path.write_text(json.dumps(_path_doc()))
    record = records.verification(path)
    assert records.is_path_record(record)
    expected = {"at_p_mm": 0.8, "rt_p_mm": 0.05, "av_pct": 2.5, "rv_pct": 0.7, "fv_mm_s": 3.0}
    assert {k: record.row[k] for k in expected} == expected
    assert (record.row["shape"], record.row["speed_mm_s"], record.row["compensated"]) == (
        "line",
        400.0,
        True,
    )
    with open_history(tmp_path / "h.sqlite") as h:
        first = h.record_verification(path)
        assert h.record_verification(path) == first
        (row,) = h.path_verifications("arm-7")
        assert h.verifications("arm-7") == []
        assert h.trackers()[0] == {
            "name": "leica:AT960:7", "model": "AT960", "serial": "7", "certificate_date": None,
        }  # fmt: skip
    assert row["measured_at"] == datetime(2026, 2, 3, 4, 5, 6)
    assert (row["at_p_mm"], row["fv_mm_s"], row["tracker"]) == (0.8, 3.0, "leica:AT960:7")
    assert row["file"] == str(path.resolve())


@pytest.mark.parametrize(
    "change, message",
    [
        ({"shape": ""}, "path.shape must name the path"),
        ({"FV_mm_s": None}, "path: 'FV_mm_s' must be a finite number"),
        ({"AT_P_mm": True}, "'AT_P_mm' must be a finite number"),
    ],
)
def test_a_path_test_without_its_shape_or_a_figure_is_refused(tmp_path, change, message):
    path = tmp_path / "line.json"
    path.write_text(json.dumps(_path_doc(**change)))
    with pytest.raises(HistoryError, match=message):
        records.verification(path)
    doc = _path_doc()
    doc["path"] = "line"
    path.write_text(json.dumps(doc))
    with pytest.raises(HistoryError, match="a path test needs its 'path' section"):
        records.verification(path)


def test_a_calibration_record_holds_its_errors_and_its_session(measured):
    path = measured / "cal0.json"
    doc = json.loads(path.read_text())
    record = records.calibration(path)
    stats = doc["stats"]
    assert record.row["held_out_rms_mm"] == stats["validation"]["after"]["position_mm"]["mean"]
    assert record.row["fit_rms_mm"] == stats["fit"]["after"]["position_mm"]["mean"]
    predicted = doc["uncertainty"]["predicted_validation_mm"]["error_mean"]
    assert record.row["predicted_mm"] == predicted
    statistics = record.row["statistics"]
    assert statistics["predicted_validation_mm"] == doc["uncertainty"]["predicted_validation_mm"]
    assert statistics["residual_sigma"] == doc["uncertainty"]["residual_sigma"]
    assert statistics["stats"] == stats and statistics["warnings"] == doc["warnings"]
    assert (
        (record.model, record.session)
        == (doc["model"], doc["session"])
        == (
            "er10l-c10",
            "s0.parquet",
        )
    )
    assert record.row["session_sha256"] == doc["session_sha256"]
    assert record.row["parameters"] == {k: float(v) for k, v in doc["deltas"].items()}
    assert set(record.row["uncertainties"]) <= set(doc["deltas"])
    assert record.row["uncertainties"]
    assert record.row["created"] == records.utc(doc["created"], "created")


def test_a_session_names_who_measured_it_its_tool_and_where_the_tracker_stood(measured, tmp_path):
    extra = {
        "measured": {"robot": "cell-3 arm", "tracker": "leica:AT960:7"},
        "tool_id": "  smr-1.5in  ",
        "tracker_pose": {"world": " cell ", "tracker2world": TRACKER2WORLD},
        "measured_at": "2026-04-01T06:30:00Z",
    }
    path = _rewrite(measured / "s0.parquet", tmp_path / "s.parquet", extra)
    record = records.session(path)
    assert (record.robot, record.tracker, record.model) == (
        "cell-3 arm",
        "leica:AT960:7",
        "er10l-c10",
    )
    assert record.row["setup"] == {
        "tool_id": "smr-1.5in",
        "tracker_pose": {"world": "cell", "tracker2world": TRACKER2WORLD},
    }
    # No timestamps in the rows: the footer's time.
    assert record.row["measured_at"] == datetime(2026, 4, 1, 6, 30)
    assert record.row["poses"] == sessions.load(path).table.num_rows
    assert record.row["file"] == str(path.resolve())


def test_a_simulated_session_is_named_after_its_model_and_seed(measured):
    record = records.session(measured / "s0.parquet")
    assert record.robot == "sim:er10l-c10:seed=3" and record.tracker is None
    assert record.row["setup"] == {} and record.row["conditions"] == {}
    mtime = os.stat(measured / "s0.parquet").st_mtime
    assert record.row["measured_at"] == datetime.fromtimestamp(int(mtime), UTC).replace(tzinfo=None)


def test_a_sessions_conditions_are_its_columns_summed_up(measured, tmp_path):
    n = sessions.load(measured / "s0.parquet").table.num_rows
    temps = [20.0 + 0.01 * i for i in range(n)]
    path = _rewrite(
        measured / "s0.parquet",
        tmp_path / "s.parquet",
        {"conditions": {"air_temperature_c": 99.0}},  # the columns win over the footer
        {"air_temperature_c": temps},
    )
    conditions = records.session(path).row["conditions"]
    assert conditions["air_temperature_c"]["min"] == pytest.approx(20.0)
    assert conditions["air_temperature_c"]["mean"] == pytest.approx(float(np.mean(temps)))
    assert conditions["poses_reporting"] == n


@pytest.mark.parametrize(
    "extra, message",
    [
        ({"tool_id": "  "}, "footer 'tool_id' must be the tool's name"),
        ({"tool_id": 3}, "footer 'tool_id' must be the tool's name"),
        ({"tracker_pose": {"tracker2world": TRACKER2WORLD}}, "'tracker_pose' must be"),
        ({"tracker_pose": {"world": "w", "tracker2world": [[1, 0], [0, 1]]}}, "rigid 4x4"),
        ({"tracker_pose": {"world": "w"}}, "rigid 4x4"),
        ({"measured_at": "yesterday"}, "footer 'measured_at'"),
    ],
)
def test_a_footer_that_declares_its_set_up_wrongly_is_refused_naming_it(
    measured, tmp_path, extra, message
):
    path = _rewrite(measured / "s0.parquet", tmp_path / "s.parquet", extra)
    with pytest.raises(HistoryError, match=message):
        records.session(path)


def test_a_scaled_tracker_pose_is_no_rigid_transform():
    scaled = np.diag([2.0, 1.0, 1.0, 1.0]).tolist()
    with pytest.raises(HistoryError, match=r"s\.parquet: footer 'tracker_pose.tracker2world'"):
        records.setup({"tracker_pose": {"world": "w", "tracker2world": scaled}}, "s.parquet")
    rigid = records.setup({"tracker_pose": {"world": "w", "tracker2world": TRACKER2WORLD}}, "s")
    assert rigid["tracker_pose"]["tracker2world"] == TRACKER2WORLD


def test_the_first_timestamp_of_the_rows_dates_a_session():
    table = pa.table(
        {"timestamp": ["2026-01-02T03:00:00+01:00", "not a time", "2026-01-02T01:30:00Z"]}
    )
    assert records.measured_time(table, {"measured_at": "2020-01-01"}, "s") == datetime(
        2026, 1, 2, 1, 30
    )
    assert records.measured_time(pa.table({"pose": [1]}), {}, "s") is None
