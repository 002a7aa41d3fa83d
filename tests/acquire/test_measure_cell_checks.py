"""``measure`` checks a plan against the arm's capsules and the cell before the first motion.

The same checks as ``calibrator plan`` (calibrator.cell): a user's plan with
a pose below the mounting plane, or a move that sweeps through it, is
refused in one line naming the pose or the move, and nothing is written:
no journal, no session (so nothing moved).
"""

import numpy as np
import pytest
from cli_kit import cli, listing, one_line_error

from calibrator import cell, planning, robots

UR10E = robots.get("ur10e")
TOOL_MM = (0.0, 0.0, 100.0)
TRACKER_AT = (2500.0, 0.0, 1500.0)  # sees the wrist-turn poses below
D = np.radians


@pytest.fixture(scope="module")
def good_plan():
    # The cases below splice into a plan without vias: the first seed that gives one.
    for seed in range(1, 20):
        made = planning.make_checked(
            UR10E, 12, cell.Cell(tracker_at_mm=TRACKER_AT), TOOL_MM, seed=seed
        )
        if made.plan.n_vias == 0:
            return made.plan.q_rad
    pytest.fail("no 12-pose plan without vias in 19 seeds")


def _measure(folder, q):
    planning.write_plan(folder / "plan.csv", planning.Plan(q))
    before = listing(folder)
    done = cli(
        "measure", "--plan", "plan.csv", "--tracker-at", ",".join(map(str, TRACKER_AT)),
        "--readings", "2", "-q", "-o", "s.parquet", cwd=folder,
    )  # fmt: skip
    assert listing(folder) == before  # no journal, no session: nothing moved
    return one_line_error(done)


def test_a_user_plan_with_the_elbow_under_the_mounting_plane_is_refused(tmp_path, good_plan):
    q = good_plan.copy()
    q[5] = D([-61, 79, -159, -34, 159, -73.0])  # the pose 13: elbow 420 mm down
    assert "plan pose 5: below mounting plane: elbow" in _measure(tmp_path, q)


def test_a_user_plan_whose_move_sweeps_under_the_mounting_plane_is_refused(tmp_path, good_plan):
    # Two safe poses 20 deg apart at wrist 1; moveJ turns it the long way, tool down.
    qa = D(np.array([0.0, 0.0, 0.0, -170.0, 90.0, 0.0]))
    qb = D(np.array([0.0, 0.0, 0.0, 170.0, 90.0, 0.0]))
    q = np.concatenate([good_plan[:6], [qa, qb], good_plan[6:]])
    checker = cell.checker(cell.arm_geometry("ur10e", UR10E.mdh, TOOL_MM), cell.Cell())
    assert not cell.pose_faults(checker, np.array([qa, qb]))[:, :3].any()
    message = _measure(tmp_path, q)
    assert "motion from pose 6 to pose 7: below mounting plane" in message


def test_a_checked_plan_is_measured_and_its_time_estimated(tmp_path, good_plan):
    planning.write_plan(tmp_path / "plan.csv", planning.Plan(good_plan))
    done = cli(
        "measure", "--plan", "plan.csv", "--tracker-at", ",".join(map(str, TRACKER_AT)),
        "--readings", "2", "-o", "s.parquet", cwd=tmp_path,
    )  # fmt: skip
    assert done.code == 0, done.stderr
    assert "estimated cell time:" in done.stderr
    assert (tmp_path / "s.parquet").is_file()
