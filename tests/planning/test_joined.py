"""Plans that do not give up (issue #39): a pose no safe move joins is replaced, not fatal.

``calibrator plan`` on ROS-Industrial's IRB 2400 stopped with "no safe move
between poses 57 and 58 ... nor through the arm held upright" having found
60 safe poses: the arm's upright elbow sits at its joint-3 limit, outside the
5-degree margin the vias keep, so no via was ever made; and a move that
could not be made safe ended the plan. Now the vias keep within the margin,
a pose that no safe move joins to the others is replaced by the next best
candidate, and the planner fails only when fewer joinable poses exist than
asked, saying how many it found.
"""

import dataclasses

import numpy as np
import pytest
from cli_kit import cli, one_line_error

from calibrator import cell as cells
from calibrator import planning, robots
from calibrator.cell import checks

UR10E = robots.get("ur10e")
TOOL_MM = (0.0, 0.0, 100.0)
#: A wall behind the arm from 300 mm off its axis: the arm held upright reaches
#: 411 mm out (its tool), so turning it there is blocked, and the wall splits
#: the poses into those on either side of it.
WALL = cells.Box("wall", (-3000.0, -10.0, -100.0), (-300.0, 10.0, 3000.0))
WALLED = cells.Cell(tracker_at_mm=(2500.0, 400.0, 300.0), boxes=(WALL,))


def _clear_all_along(chk, plan):
    """Every move of ``plan``, vias and the way back to its first pose included, sampled at
    0.1 deg of the largest joint's travel (five times the planner's step, without its
    clearance bound between samples) and checked at every sample."""
    path = np.vstack([plan.path_rad, plan.q_rad[:1]])
    samples = []
    for a, b in zip(path[:-1], path[1:], strict=True):
        steps = int(np.ceil(np.abs(b - a).max() / np.radians(0.1))) + 1
        samples.append(a + np.linspace(0.0, 1.0, steps + 1)[:, None] * (b - a))
    faults = checks.collision_faults(chk, np.vstack(samples))
    assert not faults.any(), f"{int(faults.any(axis=1).sum())} samples collide"


def test_a_chosen_pose_no_safe_move_joins_is_replaced_and_every_move_is_clear():
    # 20 of the 21 candidates with a way up can be joined; the D-optimal choice takes one
    # the wall cuts off (the old planner stopped: "no safe move between poses ...").
    made = planning.make_checked(UR10E, 12, WALLED, TOOL_MM, seed=1, n_candidates=3000)
    assert len(made.plan.q_rad) == 12
    assert made.unjoined == 1 and made.dropped["no safe move"] == 1
    chk = cells.checker(cells.arm_geometry(UR10E, UR10E.mdh, TOOL_MM), WALLED)
    assert not cells.pose_faults(chk, made.plan.q_rad).any()
    # The gate measure and program run, home being the first pose, and a finer look.
    planning.check_plan(made.plan, UR10E, WALLED, TOOL_MM, home_rad=made.plan.q_rad[0])
    _clear_all_along(chk, made.plan)
    # The replacement keeps the choice D-optimal: better than a random choice of the
    # same joinable candidates.
    chance = planning.make_checked(
        UR10E, 12, WALLED, TOOL_MM, seed=1, n_candidates=3000, selection="random"
    )
    assert planning.log_det(made.blocks) > planning.log_det(chance.blocks) + 1.0


def test_too_few_joinable_poses_fail_saying_how_many_were_found():
    with pytest.raises(planning.PlanError) as caught:
        planning.make_checked(UR10E, 21, WALLED, TOOL_MM, seed=1, n_candidates=3000)
    message = str(caught.value)
    assert message.startswith("found 20 of 21 poses: of 3000 candidates 33 pass the cell's checks")
    assert "12 of them have no safe way up, no safe move joined 1 to the other poses (" in message
    assert "obstacle" in message


def test_vias_keep_within_the_joint_margin_when_upright_is_outside_it():
    # An elbow that cannot stand straight: joint 3 from -1 deg, so upright (q3 = 0) lies
    # within the limits but outside the 5-degree margin, as the IRB 2400's joint 3 at its
    # -60 deg limit. Every via was refused there, and the first move that needed one
    # ended the plan; the vias now hold the elbow at the margin.
    limits = np.array(UR10E.joint_limits_rad)
    limits[2] = np.radians([-1.0, 180.0])
    arm = dataclasses.replace(UR10E, joint_limits_rad=limits)
    cell = cells.Cell(tracker_at_mm=(2500.0, 400.0, 300.0))
    made = planning.make_checked(arm, 30, cell, TOOL_MM, seed=0)
    assert made.plan.n_vias
    vias = np.vstack([v for v in made.plan.via_rad if len(v)])
    assert np.all(vias[:, 2] >= np.radians(4.0) - 1e-12)
    planning.check_plan(made.plan, arm, cell, TOOL_MM, home_rad=made.plan.q_rad[0])
    _clear_all_along(cells.checker(cells.arm_geometry(arm, arm.mdh, TOOL_MM), cell), made.plan)


def test_plan_says_how_many_poses_it_replaced_and_how_many_it_found(tmp_path):
    (tmp_path / "cell.yaml").write_text(
        "tracker: {at_mm: [2500, 400, 300]}\n"
        "obstacles:\n"
        "  - box: {name: wall, min_mm: [-3000, -10, -100], max_mm: [-300, 10, 3000]}\n"
    )
    args = ("plan", "--cell", "cell.yaml", "--candidates", "3000", "--seed", "1", "-o", "p.csv")
    done = cli(*args, "--poses", "12", cwd=tmp_path)
    assert done.code == 0, done.stderr
    assert "no safe way up 10, no safe move 1)" in done.stdout
    assert "note: replaced 1 chosen pose(s) that no safe move joined to the others" in done.stderr
    assert len(planning.read_plan(tmp_path / "p.csv").q_rad) == 12
    line = one_line_error(cli(*args, "--poses", "21", "--force", cwd=tmp_path))
    assert line.startswith("calibrator: error: found 20 of 21 poses: of 3000 candidates 33 pass")
