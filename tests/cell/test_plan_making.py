"""Plans made in a cell: checked candidates, distinct poses, a safe time-optimal order, files."""

import numpy as np
import pytest

from calibrator import cell, robots
from calibrator import plan as plans

UR10E = robots.get("ur10e")
TOOL_MM = (0.0, 0.0, 100.0)


def test_plan_from_all_identical_candidates_is_refused_not_reported_healthy():
    # Twelve copies of one good pose used to come out as a "d-optimal" plan with a
    # healthy-looking smallest singular value (the free set was pruned to what one
    # pose can see).
    pose = np.radians([0.0, -90.0, 60.0, -150.0, -90.0, 0.0])
    with pytest.raises(plans.PlanError, match=r"only 1 of 40 candidates .*duplicate 39"):
        plans.make_checked(UR10E, 12, cell.Cell(), TOOL_MM, candidates=np.tile(pose, (40, 1)))


def test_plan_too_few_distinct_poses_for_the_parameters_is_refused():
    good = plans.make_checked(UR10E, 30, cell.Cell(tracker_at_mm=(2500.0, 400.0, 300.0)), TOOL_MM)
    few = good.plan.q_rad[:3]
    with pytest.raises(plans.PlanError, match=r"determine only \d+ of the \d+ parameters"):
        plans.make_checked(UR10E, 3, cell.Cell(), TOOL_MM, candidates=few, selection="first")


def test_candidates_failing_checks_are_dropped_with_counts_per_reason():
    made = plans.make_checked(
        UR10E, 20, cell.Cell(tracker_at_mm=(2500.0, 400.0, 300.0)), TOOL_MM, n_candidates=6000
    )
    assert made.candidates == 6000
    assert made.dropped["acceptance angle"] > 3000
    assert made.dropped["below mounting plane"] > 0 and made.dropped["self collision"] > 0
    assert sum(made.dropped.values()) + 20 <= 6000
    chk = cell.checker(cell.arm_geometry("ur10e", UR10E.mdh, TOOL_MM), made_cell())
    assert not cell.pose_faults(chk, made.plan.q_rad).any()
    cell.check_plan(made.plan, UR10E, made_cell(), TOOL_MM)
    # The order is time-optimised: never slower than the selection order.
    assert made.ordered_time.moves_s < made.selection_time.moves_s


def made_cell():
    return cell.Cell(tracker_at_mm=(2500.0, 400.0, 300.0))


def test_a_tracker_inside_the_reach_is_refused():
    with pytest.raises(cell.CellError, match="reach envelope"):
        plans.make_checked(UR10E, 20, cell.Cell(tracker_at_mm=(300.0, 0.0, 0.0)), TOOL_MM)


def test_plan_files_round_trip_with_vias(tmp_path):
    q = np.arange(18, dtype=float).reshape(3, 6) / 10
    via = (np.zeros((0, 6)), np.full((2, 6), 0.5), np.zeros((0, 6)))
    plan = plans.Plan(q, via)
    plans.write_plan(tmp_path / "p.csv", plan)
    text = (tmp_path / "p.csv").read_text()
    assert text.splitlines()[0] == "pose,via,q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,q6_rad"
    assert [line.split(",")[:2] for line in text.splitlines()[1:]] == [
        ["0", "0"], ["", "1"], ["", "1"], ["1", "0"], ["2", "0"]
    ]  # fmt: skip
    back = plans.read_plan(tmp_path / "p.csv")
    np.testing.assert_array_equal(back.q_rad, q)
    assert [v.shape[0] for v in back.via_rad] == [0, 2, 0]
    np.testing.assert_array_equal(back.path_rad, plan.path_rad)
    # The plain reader refuses to measure via rows as poses.
    with pytest.raises(plans.PlanError, match="has via rows"):
        plans.read_csv(tmp_path / "p.csv")
    # Without vias, both readers agree.
    plans.write_plan(tmp_path / "plain.csv", plans.Plan(q))
    np.testing.assert_array_equal(plans.read_csv(tmp_path / "plain.csv"), q)
    np.testing.assert_array_equal(plans.read_plan(tmp_path / "plain.csv").q_rad, q)


@pytest.mark.parametrize(
    ("rows", "message"),
    [
        ("0,2,0,0,0,0,0,0\n", "via must be 0 or 1"),
        ("0,0,0,0,0,0,0,0\n,1,0,0,0,0,0,0\n", "via rows after the last measured pose"),
    ],
)
def test_bad_via_rows_are_refused(tmp_path, rows, message):
    path = tmp_path / "p.csv"
    path.write_text("pose,via,q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,q6_rad\n" + rows)
    with pytest.raises(plans.PlanError, match=message):
        plans.read_plan(path)
