"""Ordering (calibrator/planning/ordering.py): a made plan's way back home is safe.

A made plan's move from its last pose back to its first (a program's home) is safe:
``program`` returns home (by default the first pose) after the last pose along
the joint-space line, and refuses a plan whose way back collides: the planner
starts its cycle after a safe move so that its own plans always pass.
"""

import pytest

from calibrator import cell as cells
from calibrator import planning, robots

UR10E = robots.get("ur10e")
TOOL_MM = (0.0, 0.0, 100.0)


@pytest.mark.parametrize(("seed", "tracker"), [(0, (2500, 400, 300)), (3, (-400, 2600, 500))])
def test_every_move_of_a_made_plan_and_the_way_back_home_pass(seed, tracker):
    cell = cells.Cell(tracker_at_mm=tracker)
    plan = planning.make_checked(UR10E, 10, cell, TOOL_MM, seed=seed).plan
    chk = cells.checker(cells.arm_geometry(UR10E.name, UR10E.mdh, TOOL_MM), cell)
    back = cells.motion_faults(chk, plan.q_rad[-1:], plan.q_rad[:1])
    assert not back.any()
    # The whole program's gate passes too, home being the first pose.
    planning.check_plan(plan, UR10E, cell, TOOL_MM, home_rad=plan.q_rad[0])
