"""Plan-file cases the planning tests did not reach. Found by mutation testing (issue 44).

A plan made for an arm whose controller turns joints the other way (KUKA's 1
and 6), with a tracker and a tool of three different coordinates, round-trips
through its file; a file without a model column is read in the caller's arm's
angles; a run elsewhere than the plan was made for is refused; and the
refusals of a bad origin or joints column name what is wrong.
"""

from __future__ import annotations

import numpy as np
import pytest

from calibrator import cell as cells
from calibrator import planning, robots
from calibrator.planning import PlanError, planfile

KUKA = robots.get("kuka-kr6-r900")
HEADER = "q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,q6_rad"
Q = np.array([[0.1, -0.2, 0.3, -0.4, 0.5, -0.6], [1.0, 1.1, 1.2, 1.3, 1.4, 1.5]])


def _origin(**changes):
    values = {
        "model": KUKA.name,
        "tool_mm": (10.0, 20.0, 30.0),
        "tracker_at_mm": (2500.0, -700.0, 400.0),
        "model_sha256": KUKA.digest,
    }
    return planning.PlanOrigin(**(values | changes))


def test_a_plan_for_a_reversing_controller_round_trips_with_its_origin(tmp_path):
    via = (np.zeros((0, 6)), np.full((1, 6), 0.25))
    plan = planning.Plan(Q, via, _origin())
    planning.write_plan(tmp_path / "p.csv", plan)
    text = (tmp_path / "p.csv").read_text().splitlines()
    # The file holds the controller's angles: joints 1 and 6 the other way.
    first = dict(zip(text[0].split(","), text[1].split(","), strict=True))
    assert float(first["q1_rad"]) == -Q[0, 0] and float(first["q6_rad"]) == -Q[0, 5]
    assert float(first["q2_rad"]) == Q[0, 1]
    back = planning.read_plan(tmp_path / "p.csv")
    np.testing.assert_array_equal(back.q_rad, Q)
    np.testing.assert_array_equal(back.via_rad[1], via[1])
    assert back.origin == plan.origin
    assert back.origin.tool_mm == (10.0, 20.0, 30.0)
    assert back.origin.tracker_at_mm == (2500.0, -700.0, 400.0)


def test_a_plan_without_a_tracker_writes_its_columns_empty_and_reads_none(tmp_path):
    plan = planning.Plan(Q, (np.zeros((0, 6)),) * 2, _origin(tracker_at_mm=None))
    planning.write_plan(tmp_path / "p.csv", plan)
    header, row = (tmp_path / "p.csv").read_text().splitlines()[:2]
    cells = dict(zip(header.split(","), row.split(","), strict=True))
    assert cells["tracker_x_mm"] == cells["tracker_y_mm"] == cells["tracker_z_mm"] == ""
    assert planning.read_plan(tmp_path / "p.csv").origin.tracker_at_mm is None


def test_a_file_naming_no_arm_is_read_in_the_callers_arms_angles(tmp_path):
    path = tmp_path / "p.csv"
    rows = "".join(",".join(repr(float(v)) for v in r) + "\n" for r in Q)
    path.write_text(f"{HEADER}\n{rows}")
    expected = KUKA.convention.to_model(Q)
    assert not np.allclose(expected, Q)
    np.testing.assert_array_equal(planning.read_csv(path, KUKA), expected)
    np.testing.assert_array_equal(planning.read_plan(path, KUKA).q_rad, expected)
    np.testing.assert_array_equal(planning.read_csv(path), Q)  # no arm: as written


def test_a_run_with_the_tracker_elsewhere_is_refused_and_one_close_by_is_not():
    plan = planning.Plan(Q, (np.zeros((0, 6)),) * 2, _origin())
    near = (2500.0 + 0.8 * planfile.ORIGIN_TOLERANCE_MM, -700.0, 400.0)
    tracker, tool = planfile.made_for(plan, KUKA, near, None)
    assert tracker == near and tool == (10.0, 20.0, 30.0)
    far = (2500.0, -700.0 + 1.2 * planfile.ORIGIN_TOLERANCE_MM, 400.0)
    with pytest.raises(PlanError, match="made for the tracker at"):
        planfile.made_for(plan, KUKA, far, None)


def _written(tmp_path, header, row):
    path = tmp_path / "p.csv"
    path.write_text(f"{header}\n{row}\n")
    return path


def test_an_origin_without_its_other_columns_names_them(tmp_path):
    path = _written(tmp_path, f"model,{HEADER}", "ur10e,0,0,0,0,0,0")
    with pytest.raises(PlanError) as info:
        planning.read_plan(path)
    missing = ", ".join(c for c in planfile.ORIGIN_COLUMNS if c != "model")
    assert str(info.value) == f"{path}: has a model column but not {missing}"


def _origin_file(tmp_path, digest="", tracker=("1", "2", "3")):
    header = ",".join((*planfile.ORIGIN_COLUMNS, HEADER))
    row = ",".join(("ur10e", digest, *tracker, "0", "0", "100", "0,0,0,0,0,0"))
    return _written(tmp_path, header, row)


def test_a_bad_digest_is_shown_cut_to_80_characters(tmp_path):
    digest = "md5:" + "ab" * 60
    path = _origin_file(tmp_path, digest=digest)
    with pytest.raises(PlanError) as info:
        planning.read_plan(path)
    assert str(info.value).endswith(f"digest: {digest[:80]!r}")


def test_a_tracker_beyond_100_km_is_refused_naming_the_tracker(tmp_path):
    path = _origin_file(tmp_path, tracker=("1e6", "0", "0"))
    with pytest.raises(PlanError, match=r"the tracker position .* is beyond \+-100000 mm"):
        planning.read_plan(path)


def test_a_joints_column_that_changes_between_rows_is_refused_naming_both(tmp_path):
    path = tmp_path / "p.csv"
    path.write_text(f"joints,{HEADER}\ncontroller,0,0,0,0,0,0\nmodel,1,1,1,1,1,1\n")
    with pytest.raises(PlanError, match="must be one of controller, model on every row, got "
                       "controller, model"):  # fmt: skip
        planning.read_csv(path)


def test_a_pose_repeated_across_vias_is_refused_naming_its_file_lines(tmp_path):
    path = tmp_path / "p.csv"
    path.write_text(
        f"pose,via,{HEADER}\n0,0,0,0,0,0,0,0\n,1,5,5,5,5,5,5\n1,0,1,1,1,1,1,1\n2,0,0,0,0,0,0,0\n"
    )
    with pytest.raises(PlanError, match="lines 2 and 5 are the same pose"):
        planning.read_plan(path)


def test_a_two_pose_plan_whose_one_move_hits_the_crate_is_refused_naming_both_ends():
    from test_closing_move import CELL, POSES, TOOL_MM, UR10E

    low_left, low_right = POSES[0], POSES[3]  # safe poses; the move between sweeps the crate
    plan = planning.Plan(np.array([low_left, low_right]), (np.zeros((0, 6)),) * 2)
    with pytest.raises(cells.CellError) as info:
        planning.check_plan(plan, UR10E, CELL, TOOL_MM)
    assert str(info.value).startswith("plan motion from pose 0 to pose 1: ")
    assert str(info.value).endswith(" along the way; nothing moved")
    # The same move after a safe one: named by its own two ends.
    plan = planning.Plan(np.array([POSES[1], low_left, low_right]), (np.zeros((0, 6)),) * 3)
    with pytest.raises(cells.CellError, match="^plan motion from pose 1 to pose 2: "):
        planning.check_plan(plan, UR10E, CELL, TOOL_MM)


def test_one_failing_pose_is_named_without_a_count():
    from test_closing_move import CELL, POSES, TOOL_MM, UR10E

    into_crate = POSES[0].copy()
    into_crate[0] = 0.0  # the low arm reaching out into the crate, not beside it
    plan = planning.Plan(np.array([POSES[1], into_crate, POSES[2]]), (np.zeros((0, 6)),) * 3)
    with pytest.raises(cells.CellError) as info:
        planning.check_plan(plan, UR10E, CELL, TOOL_MM)
    said = str(info.value)
    assert said.startswith("plan pose 1: ") and said.endswith("; nothing moved")
    assert "poses fail" not in said
    two = planning.Plan(
        np.array([into_crate, POSES[1], into_crate + 0.01]), (np.zeros((0, 6)),) * 3
    )
    with pytest.raises(cells.CellError, match=r"\(2 poses fail\); nothing moved$"):
        planning.check_plan(two, UR10E, CELL, TOOL_MM)


def test_a_value_outside_the_number_grammar_is_refused_naming_the_file(tmp_path):
    path = _written(tmp_path, HEADER, "0,0_5,0,0,0,0")
    with pytest.raises(PlanError) as info:
        planning.read_csv(path)
    assert str(path) in str(info.value) and "0_5" in str(info.value)
