"""Ordering (calibrator/planning/ordering.py): a made plan's way back home is safe.

A made plan's move from its last pose back to its first (a program's home) is safe:
``program`` returns home (by default the first pose) after the last pose along
the joint-space line, and refuses a plan whose way back collides: the planner
starts its cycle after a safe move so that its own plans always pass.
"""

import numpy as np
import pytest

from calibrator import cell as cells
from calibrator import planning, robots
from calibrator.planning import ordering, sampling

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


#: Five poses whose shortest-time order (1, 2, 4, 0, 3) has only safe moves but whose
#: way back from its last pose to its first sweeps the arm into itself (deg).
CLOSING_UNSAFE_DEG = [
    [-66.9, -138.8, -58.0, -1.4, 168.3, 122.0],
    [-124.7, -44.5, 109.5, 159.6, -146.6, -171.0],
    [28.8, -95.9, -13.2, 83.3, -74.7, -45.8],
    [-171.8, -97.8, -22.7, -58.7, -88.6, 174.9],
    [65.6, -58.0, -99.5, -49.0, 42.0, 44.1],
]


def test_an_order_whose_way_home_is_unsafe_starts_after_a_safe_move_instead():
    # Issue #44: the plan-ordering tests never needed the closing move turned.
    cell = cells.Cell(tracker_at_mm=(2500, 400, 300))
    chk = cells.checker(cells.arm_geometry(UR10E.name, UR10E.mdh, TOOL_MM), cell)
    q = np.radians(CLOSING_UNSAFE_DEG)
    speed, accel = UR10E.move_speed_cap_rad_s, UR10E.move_accel_cap_rad_s2
    plain = cells.order_poses(cells.time_matrix(q, speed, accel))
    assert not cells.motion_faults(chk, q[plain[:-1]], q[plain[1:]]).any()
    assert cells.motion_faults(chk, q[plain[-1:]], q[plain[:1]]).any()
    box = sampling.joint_box(UR10E.joint_limits_rad, np.radians(5.0))
    ordered = ordering.order_joined(chk, q, box, speed, accel)
    assert not ordered.unjoined
    # The same cycle, started after a safe move: every pose once, the way back home safe,
    # the old way home an inner move through the arm held upright.
    start = int(np.flatnonzero(plain == ordered.order[0])[0])
    np.testing.assert_array_equal(ordered.order, np.roll(plain, -start))
    assert start != 0
    assert ordered.plan.n_vias
    assert not cells.motion_faults(chk, q[ordered.order[-1:]], q[ordered.order[:1]]).any()
    planning.check_plan(ordered.plan, UR10E, cell, TOOL_MM, home_rad=ordered.plan.q_rad[0])
