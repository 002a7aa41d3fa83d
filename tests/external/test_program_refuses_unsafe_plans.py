"""``calibrator program`` runs measure's whole-plan check and writes nothing it refuses.

For an arm the controller runs on its own the program is the only gate: a
pose, a via or a move (home -> first pose and last pose -> home included)
that the cell or the tracker refuses must never become a program, in any
language.
"""

import numpy as np
import pytest
from cli_kit import cli, listing, one_line_error
from plan_kit import CHECKED_PLAN_TRACKER_MM

from calibrator import cell as cells
from calibrator import planning, robots
from calibrator.model import frames, kinematics

ARM = robots.get("ur10e")
#: Elbow 496 mm below the mounting plane (the red-team's pose), rad.
BELOW_FLOOR = np.array([-1.0647, 1.3788, -2.7751, -0.5934, 2.7751, -1.2741])
FORMATS = ["cal.script", "CAL.src", "cal.mod", "cal.ls", "cal.csv"]
TRACKER = ",".join(f"{v:g}" for v in CHECKED_PLAN_TRACKER_MM)


def _refused(tmp_path, plan, *args):
    """Run ``program`` on ``plan`` (a Plan) and return its one error line; nothing is written."""
    planning.write_plan(tmp_path / "plan.csv", plan)
    before = listing(tmp_path)
    line = one_line_error(cli("program", "plan.csv", *args, cwd=tmp_path))
    assert listing(tmp_path) == before
    return line


def _with_pose(plan, i, q):
    rows = plan.q_rad.copy()
    rows[i] = q
    return planning.Plan(rows, plan.via_rad, plan.origin)


def test_the_shared_plan_is_written_with_its_tracker(tmp_path, checked_plan):
    planning.write_plan(tmp_path / "plan.csv", checked_plan)
    done = cli("program", "plan.csv", "-o", "cal.script", "--tracker-at", TRACKER, cwd=tmp_path)
    assert done.code == 0, done.stderr
    assert "not checked" not in done.stderr


@pytest.mark.parametrize("name", FORMATS)
def test_a_pose_below_the_mounting_plane_is_refused_in_every_language(tmp_path, checked_plan, name):
    line = _refused(tmp_path, _with_pose(checked_plan, 5, BELOW_FLOOR), "-o", name)
    assert "plan pose 5: below mounting plane" in line


@pytest.mark.parametrize("name", FORMATS)
def test_a_via_below_the_mounting_plane_is_refused_in_every_language(tmp_path, checked_plan, name):
    vias = list(checked_plan.via_rad)
    vias[3] = BELOW_FLOOR[None]
    plan = planning.Plan(checked_plan.q_rad, tuple(vias), checked_plan.origin)
    line = _refused(tmp_path, plan, "-o", name)
    assert "via 0 before pose 3: below mounting plane" in line


@pytest.mark.parametrize("name", FORMATS)
def test_a_colliding_move_is_refused_in_every_language(tmp_path, checked_plan, name):
    # The planner routed pose 0 -> 1 through vias because the direct move is unsafe.
    assert len(checked_plan.via_rad[1])
    vias = list(checked_plan.via_rad)
    vias[1] = np.zeros((0, 6))
    plan = planning.Plan(checked_plan.q_rad, tuple(vias), checked_plan.origin)
    line = _refused(tmp_path, plan, "-o", name)
    assert "plan motion from pose 0 to pose 1" in line and "along the way" in line


def test_a_home_below_the_mounting_plane_is_refused(tmp_path, checked_plan):
    home = ",".join(f"{v:g}" for v in np.degrees(BELOW_FLOOR))
    line = _refused(tmp_path, checked_plan, "-o", "cal.src", "--home", home)
    assert "plan home: below mounting plane" in line


def test_the_move_back_home_is_checked(tmp_path, checked_plan):
    # A home every pose can be reached from but the last: the way back is refused.
    chk = cells.checker(cells.arm_geometry(ARM.name, ARM.mdh, (0, 0, 100)), cells.Cell())
    last = checked_plan.q_rad[-1]
    rng = np.random.default_rng(3)
    box = planning.joint_box(ARM.joint_limits_rad, np.radians(5))
    for home in planning.sample(box, 4000, "random", 3)[rng.permutation(4000)]:
        ok_home = not cells.pose_faults(chk, home[None])[0, :4].any()
        if ok_home and cells.motion_faults(chk, last[None], home[None]).any():
            break
    else:
        pytest.fail("no home found whose way back from the last pose collides")
    text = ",".join(f"{v:.9f}" for v in np.degrees(home))
    line = _refused(tmp_path, checked_plan, "-o", "cal.mod", "--home", text)
    assert "home" in line and "nothing moved" in line


def test_poses_that_do_not_face_the_tracker_are_refused(tmp_path, checked_plan):
    x, y, z = CHECKED_PLAN_TRACKER_MM
    # A plan file that does not say where its tracker was (an older or hand-made one).
    plan = planning.Plan(checked_plan.q_rad, checked_plan.via_rad)
    line = _refused(tmp_path, plan, "-o", "cal.ls", "--tracker-at", f"{-x},{-y},{z}")
    assert "acceptance angle" in line or "line of sight" in line


def test_a_plan_made_for_another_tracker_position_is_refused_naming_both(tmp_path, checked_plan):
    x, y, z = CHECKED_PLAN_TRACKER_MM
    line = _refused(tmp_path, checked_plan, "-o", "cal.ls", "--tracker-at", f"{-x},{-y},{z}")
    assert f"made for the tracker at {x:g},{y:g},{z:g} mm, not {-x:g},{-y:g},{z:g}" in line


def test_a_plan_made_for_another_arm_is_refused_naming_both(tmp_path, checked_plan):
    line = _refused(tmp_path, checked_plan, "-o", "cal.ls", "--model", "ur5e")
    assert "--model ur5e but " in line and " is of a ur10e" in line


def test_the_plan_files_tracker_is_checked_without_tracker_at(tmp_path, checked_plan):
    planning.write_plan(tmp_path / "plan.csv", checked_plan)
    done = cli("program", "plan.csv", "-o", "cal.script", cwd=tmp_path)
    assert done.code == 0, done.stderr
    assert "not checked" not in done.stderr


def test_a_cell_file_tracker_inside_the_reach_is_refused(tmp_path, checked_plan):
    (tmp_path / "cell.yaml").write_text("tracker:\n  at_mm: [400, 0, 300]\n")
    plan = planning.Plan(checked_plan.q_rad, checked_plan.via_rad)  # no tracker recorded
    line = _refused(tmp_path, plan, "-o", "cal.script", "--cell", "cell.yaml")
    assert "inside the ur10e's reach" in line


def test_a_cell_file_obstacle_refuses_the_pose_it_holds(tmp_path, checked_plan):
    tool = frames.transform(translation=(0.0, 0.0, 100.0))
    point = kinematics.forward(ARM.mdh, checked_plan.q_rad[4:5], tool)[0, :3, 3]
    lo, hi = point - 30, point + 30
    (tmp_path / "cell.yaml").write_text(
        "obstacles:\n  - box: {name: fixture, "
        f"min_mm: [{lo[0]:.1f}, {lo[1]:.1f}, {lo[2]:.1f}], "
        f"max_mm: [{hi[0]:.1f}, {hi[1]:.1f}, {hi[2]:.1f}]}}\n"
    )
    line = _refused(tmp_path, checked_plan, "-o", "cal.csv", "--cell", "cell.yaml")
    assert "fixture" in line


def test_too_few_poses_are_refused_as_measure_refuses_them(tmp_path):
    line = _refused(tmp_path, planning.Plan(BELOW_FLOOR[None]), "-o", "d.script")
    assert "need at least" in line
