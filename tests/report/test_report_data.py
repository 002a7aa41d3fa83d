"""What the report gathers: facts, optional entries, and per-pose errors of arms known exactly."""

import numpy as np
import pyarrow as pa
import pytest
from report_kit import calibration_of

from calibrator import calibration, robots
from calibrator.errors import CalibrationError
from calibrator.report import data
from calibrator.session import Session
from calibrator.simulate import simulate


def test_units_of_known_and_unknown_names():
    for name, unit in (
        ("a1", "mm"),
        ("alpha2", "rad"),
        ("theta6", "rad"),
        ("d4", "mm"),
        ("base_x", "mm"),
        ("tool_z", "mm"),
        ("tool_ry", "rad"),
        ("alpha9", "rad"),  # not in the parameter list: guessed from the name
        ("theta_x", "rad"),
        ("beta7", "rad"),
        ("link_rx", "rad"),
        ("link_ry", "rad"),
        ("link_rz", "rad"),
        ("link_x", "mm"),
        ("offset", "mm"),
    ):
        assert data.unit_of(name) == unit, name


def test_facts_title_and_entries_of_a_full_document():
    doc = {
        "model": "ur10e",
        "session": "recorded.parquet",
        "method": "hybrid",
        "loss": "huber",
        "k": 20000.0,
        "validation_fraction": 0.2,
        "seed": 3,
        "created": "2026-11-24T07:00:00+00:00",
        "stats": {"fit": {"before": {"n": 4}}},
        "deltas": {"a1": 1, "theta2": 0.5},
        "uncertainty": {
            "standard_errors": {"a1": 0.25},
            "residual_sigma": {"position_mm": 0.0123, "orientation_rad": 0.0005},
            "strong_correlations": [{"a": "a1", "b": "theta2", "r": -0.95}],
            "predicted_validation_mm": {"error_mean": 0.031},
        },
        "standard_errors": {"a1": 9.0},
        "dropped_parameters": [{"name": "d1", "reason": "no effect"}],
        "solver": {"convergence": [[0, 5.0], [10, 1.0]], "standard_errors": {"a1": 8.0}},
        "convergence": [7.0],
        "warnings": ["two poses alike", 3],
        "outliers": [4, 9],
    }
    content = data.collect(calibration_of(doc), None, "cal.json", "s.parquet")
    assert content.title == "Calibration of ur10e"
    assert content.facts == [
        ("calibration", "cal.json"),
        ("session", "s.parquet"),
        ("model", "ur10e"),
        ("method", "hybrid"),
        ("loss", "huber"),
        ("orientation weight k (mm^2/rad^2)", 20000.0),
        ("validation fraction", 0.2),
        ("seed", 3),
        ("residual sigma", "0.0123 mm per axis, 0.5000 mrad"),
        ("predicted held-out position error", "0.0310 mm mean"),
        ("strongly correlated pairs (|r| > 0.9)", "a1/theta2 -0.95"),
        ("outlier poses set aside", "4, 9"),
        ("identified (UTC)", "2026-11-24T07:00:00+00:00"),
    ]
    assert content.stats == {"fit": {"before": {"n": 4}}}
    assert content.deltas == {"a1": 1.0, "theta2": 0.5}
    assert all(type(v) is float for v in content.deltas.values())
    assert content.standard_errors == {"a1": 0.25}  # the uncertainty block comes first
    assert content.dropped == [{"name": "d1", "reason": "no effect"}]
    np.testing.assert_array_equal(content.convergence, [[0, 5.0], [10, 1.0]])  # solver's first
    assert content.warnings == ["two poses alike", "3"]
    assert [r["name"] for r in content.parameters] == ["a1", "theta2"]
    assert content.poses is None
    why = "give the session file to draw per-pose errors"
    assert content.notes == {"pose_errors": why, "error_cdf": why, "error_vs_distance": why}


def test_facts_of_a_bare_document_say_what_is_not_recorded():
    content = data.collect(calibration_of({}))
    assert content.title == "Calibration of a robot arm"
    assert content.facts == [
        ("calibration", "(in memory)"),
        ("session", "not recorded"),
        ("model", "nominal table in the session"),
        ("method", "not recorded"),
        ("loss", "not recorded"),
        ("orientation weight k (mm^2/rad^2)", "not recorded"),
        ("validation fraction", "not recorded"),
        ("seed", "not recorded"),
    ]
    assert (content.stats, content.deltas, content.dropped, content.warnings) == ({}, {}, [], [])
    assert content.standard_errors is None and content.convergence is None
    assert content.notes["convergence"] == ("not recorded (no swarm, or an older calibration file)")
    recorded = data.collect(calibration_of({"session": "from.parquet", "outlier_poses": []}))
    assert recorded.facts[1] == ("session", "from.parquet") and len(recorded.facts) == 8


def test_the_outliers_of_a_robust_fit_are_on_the_page():
    """The writer's ``outliers`` (and the older name ``outlier_poses``) reach the page."""
    for key in ("outliers", "outlier_poses"):
        content = data.collect(calibration_of({key: [7, 12]}))
        assert ("outlier poses set aside", "7, 12") in content.facts
        assert "7, 12" in report_page(content)


def report_page(content):
    from calibrator.report import page

    return page.html(content, {})


def test_standard_errors_and_convergence_from_their_other_places():
    top = data.collect(
        calibration_of({"standard_errors": {"a1": 0.5}, "solver": {"standard_errors": {"a1": 1}}})
    )
    assert top.standard_errors == {"a1": 0.5}
    solver = data.collect(calibration_of({"solver": {"standard_errors": {"a1": 1}}}))
    assert solver.standard_errors == {"a1": 1.0}
    old = data.collect(calibration_of({"convergence": [3.0, 2.0, 2.0]}))  # one cost per generation
    np.testing.assert_array_equal(old.convergence, [[0, 3.0], [1, 2.0], [2, 2.0]])
    assert "convergence" not in old.notes


@pytest.mark.parametrize(
    ("doc", "says"),
    [
        (
            {"convergence": [[0, 1, 2]]},
            "cal.json: malformed for the report "
            "('convergence' is neither costs nor [generation, cost] pairs)",
        ),
        (
            {"solver": {"convergence": [[[0, 1]]]}},
            "cal.json: malformed for the report "
            "('convergence' is neither costs nor [generation, cost] pairs)",
        ),
        ({"convergence": [[0, "x"]]}, "cal.json: malformed for the report ("),
        ({"uncertainty": {"standard_errors": {"a1": "x"}}}, "cal.json: malformed for the report ("),
    ],
)
def test_malformed_entries_are_one_line_naming_the_file(doc, says):
    with pytest.raises(CalibrationError) as caught:
        data.collect(calibration_of(doc), calibration_path="cal.json")
    assert str(caught.value).startswith(says)
    assert "\n" not in str(caught.value)


# --- per-pose errors of arms whose truth is known --------------------------------


def known_arm(frame="tracker", errors="none", tool_offset_mm=0.0, poses=12):
    table, meta, truth = simulate(
        model="ur10e",
        poses=poses,
        seed=11,
        frame=frame,
        errors=errors,
        tool_offset_mm=tool_offset_mm,
    )
    numbers = pa.array([10 * (i + 1) for i in range(poses)], type=table.schema.field("pose").type)
    table = table.set_column(table.schema.get_field_index("pose"), "pose", numbers)
    doc = {
        "nominal_mdh": robots.get("ur10e").mdh.tolist(),
        "mdh": calibration.mdh_records(truth.mdh),
        "base2tracker": truth.base2tracker.tolist(),
        "flange2tool": truth.flange2tool.tolist(),
        "free_parameters": ["a2", "d4"],
        "validation_poses": [1, 4],
        "stats": {
            "fit": {"before": {"n": poses - 2}},
            "validation": {"before": {"n": 2}},
        },
    }
    return table, meta, truth, doc


def shifted(table, rows, mm):
    x = table.column("x_mm").to_numpy().copy()
    x[rows] += mm
    return table.set_column(table.schema.get_field_index("x_mm"), "x_mm", pa.array(x))


def test_held_out_poses_do_not_place_the_nominal_model():
    table, meta, _, doc = known_arm()
    # Held-out poses moved 100 mm: the nominal arm is placed on the fitted poses only.
    moved = shifted(table, [1, 4], 100.0)
    poses = data.pose_errors(calibration_of(doc), Session(moved, meta))
    np.testing.assert_array_equal(poses.pose, [10 * (i + 1) for i in range(12)])
    np.testing.assert_array_equal(poses.held_out, np.isin(np.arange(12), [1, 4]))
    assert poses.origin == "tracker"
    fitted = ~poses.held_out
    np.testing.assert_allclose(poses.before_mm[fitted], 0, atol=1e-6)
    np.testing.assert_allclose(poses.before_mm[poses.held_out], 100.0, rtol=1e-9)
    np.testing.assert_allclose(poses.after_mm[fitted], 0, atol=1e-6)
    np.testing.assert_allclose(poses.after_mm[poses.held_out], 100.0, rtol=1e-9)
    points = np.column_stack([moved.column(c).to_numpy() for c in ("x_mm", "y_mm", "z_mm")])
    np.testing.assert_allclose(poses.distance_mm, np.linalg.norm(points, axis=1))
    assert 1000 < poses.distance_mm.min()  # the tracker stands metres away


def test_before_is_the_nominal_arm_and_after_the_identified_one():
    table, meta, truth, doc = known_arm(errors="random")
    poses = data.pose_errors(calibration_of(doc), Session(table, meta), "s.parquet")
    np.testing.assert_allclose(poses.after_mm, 0, atol=1e-6)  # the true arm
    assert poses.before_mm.min() > 0.05  # the nominal arm misses by the kinematic errors
    # The identified frames are used as recorded: a base 1 mm off shows in every pose.
    off = dict(doc, base2tracker=truth.base2tracker.tolist())
    off["base2tracker"][1][3] += 1.0
    np.testing.assert_allclose(
        data.pose_errors(calibration_of(off), Session(table, meta)).after_mm, 1.0
    )
    tool = dict(doc, flange2tool=truth.flange2tool.tolist())
    tool["flange2tool"][2][3] += 2.0  # along the flange axis: 2 mm in every pose
    np.testing.assert_allclose(
        data.pose_errors(calibration_of(tool), Session(table, meta)).after_mm, 2.0
    )


@pytest.mark.parametrize(
    ("free", "dropped", "fitted"),
    [
        (["a2"], [], False),
        (["a2", "tool_y"], [], True),
        (["a2"], [{"name": "tool_z", "reason": "no effect"}], True),
        (["a2", "tool_rx"], [], False),  # a tool rotation alone leaves the point known
    ],
)
def test_an_unknown_tool_point_is_fitted_before_the_nominal_arm_is_scored(free, dropped, fitted):
    table, meta, _, doc = known_arm(tool_offset_mm=5.0)
    doc = dict(doc, free_parameters=free, dropped_parameters=dropped)
    poses = data.pose_errors(calibration_of(doc), Session(table, meta))
    if fitted:
        np.testing.assert_allclose(poses.before_mm, 0, atol=1e-4)
    else:  # the session's guess is 5 mm off the true tool point
        assert poses.before_mm.max() > 1.0


def test_a_base_frame_session_measures_distance_from_the_robot_base():
    table, meta, _, doc = known_arm(frame="base")
    doc["base2tracker"] = np.eye(4).tolist()
    poses = data.pose_errors(calibration_of(doc), Session(table, meta))
    assert poses.origin == "robot base"
    np.testing.assert_allclose(poses.before_mm, 0, atol=1e-6)
    assert poses.distance_mm.max() < 2000  # within the arm's reach of its base


@pytest.mark.parametrize(
    ("fit", "held", "validation_poses"),
    [(11, 2, [1, 4]), (9, 2, [1, 4]), (0, 0, [3, 12])],
)
def test_a_session_of_another_size_is_refused(fit, held, validation_poses):
    table, meta, _, doc = known_arm()
    doc["stats"] = {"fit": {"before": {"n": fit}}, "validation": {"before": {"n": held}}}
    doc["validation_poses"] = validation_poses
    expected = fit + held
    with pytest.raises(CalibrationError) as caught:
        data.collect(calibration_of(doc), Session(table, meta), "c.json", "other.parquet")
    assert str(caught.value) == (
        f"other.parquet has 12 poses but the calibration was identified from {expected}: "
        "give the session it was made from"
    )
    with pytest.raises(CalibrationError, match="^the session has 12 poses"):
        data.pose_errors(calibration_of(doc), Session(table, meta))


def test_a_session_without_statistics_or_held_out_poses_is_taken_whole():
    table, meta, _, doc = known_arm()
    doc = {k: v for k, v in doc.items() if k not in ("stats", "validation_poses")}
    content = data.collect(calibration_of(doc), Session(table, meta), "c.json", "s.parquet")
    assert not content.poses.held_out.any() and len(content.poses.pose) == 12
    assert not set(content.notes) & {"pose_errors", "error_cdf", "error_vs_distance"}
    last = dict(doc, validation_poses=[11])  # the last pose may be held out
    assert data.pose_errors(calibration_of(last), Session(table, meta)).held_out[11]


def test_the_measurement_is_described_from_the_session():
    """Date, robot and tracker, readings per pose: what an engineer checks first."""
    from dataclasses import replace
    from datetime import UTC, datetime, timedelta

    table, meta, _, doc = known_arm()
    start = datetime(2026, 11, 3, 9, 0, tzinfo=UTC)
    stamps = pa.array([start + timedelta(minutes=i) for i in range(12)])
    for name, values in (("timestamp", stamps), ("n_readings", pa.array([20] * 11 + [12]))):
        if name in table.column_names:
            table = table.drop_columns([name])
        table = table.append_column(name, values)
    measured = {"robot": "ur://10.0.0.5:ur10e", "tracker": "AT960 #12345"}
    meta = replace(meta, extra={"measured": measured})
    facts = dict(data.collect(calibration_of(doc), Session(table, meta)).facts)
    assert facts["measured"] == f"{stamps[0].as_py()} to {stamps[11].as_py()}"
    assert facts["robot"] == "ur://10.0.0.5:ur10e" and facts["tracker"] == "AT960 #12345"
    assert facts["readings per pose"] == "12 to 20"
    bare = dict(data.collect(calibration_of(doc), Session(*known_arm()[:2])).facts)
    assert bare["robot"] == bare["tracker"] == "not recorded"
    assert "measured" not in bare  # the simulation records no times
