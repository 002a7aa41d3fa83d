"""Ordering's other parts (calibrator/planning/ordering.py): ways up, refusals, time estimates.

A UR10e between a crate (in front, at joint 1 = 0) and a shelf above its
left low pose: from there the arm cannot rise (every way up passes through
the shelf), so the move from the left low pose to the right one has no
order and no vias that make it safe, and ``order_joined`` returns it naming
the poses and the fault.
"""

from __future__ import annotations

import numpy as np
import pytest

from calibrator import cell as cells
from calibrator import planning, robots
from calibrator.cell import timing
from calibrator.planning import ordering
from calibrator.planning.sampling import joint_box

UR10E = robots.get("ur10e")
TOOL_MM = (0.0, 0.0, 100.0)
LOW = [-0.7, 1.0, -1.87, -1.5708, 0.0]
SIDE = np.radians(60.0)
#: Low left (under the shelf) and low right; the crate between them.
POSES = np.array([[-SIDE, *LOW], [SIDE, *LOW]])
CRATE = cells.Box("crate", (-1300.0, -300.0, 0.0), (-600.0, 300.0, 700.0))
SHELF = cells.Box("shelf", (-787.0, 479.0, 750.0), (-287.0, 979.0, 850.0))


@pytest.fixture
def chk():
    cell = cells.Cell(boxes=(CRATE, SHELF))
    return cells.checker(cells.arm_geometry(UR10E.name, UR10E.mdh, TOOL_MM), cell)


def test_a_pose_under_a_shelf_cannot_rise_and_one_beside_it_can(chk):
    assert not cells.checks.collision_faults(chk, POSES).any()
    np.testing.assert_array_equal(ordering.can_rise(chk, POSES), [False, True])
    np.testing.assert_array_equal(ordering.can_rise(chk, POSES[::-1]), [True, False])


def test_a_move_no_order_and_no_way_over_makes_safe_is_returned_naming_it(chk):
    box = joint_box(UR10E.joint_limits_rad, np.radians(5.0))
    ordered = ordering.order_joined(chk, POSES, box, 1.0, 2.0)
    # Both ways (the way home too); the planner then replaces one of the two poses.
    assert {(a, b) for a, b, _ in ordered.unjoined} == {(0, 1), (1, 0)}
    assert {why for _, _, why in ordered.unjoined} == {"obstacle"}


def test_the_ways_up_raise_shoulder_and_elbow_together_or_one_first_then_the_wrist(chk):
    up2, up3 = chk.geometry.upright_rad
    w4, w5 = chk.geometry.neutral_wrist_rad
    paths = ordering._rise_paths(chk, POSES)
    assert [p.shape for p in paths] == [(2, 2, 6), (2, 3, 6), (2, 3, 6)]
    together, elbow_first, shoulder_first = paths
    for row, q in enumerate(POSES):
        upright = np.array([q[0], up2, up3, q[3], q[4], q[5]])
        neutral = np.array([q[0], up2, up3, w4, w5, q[5]])
        np.testing.assert_array_equal(together[row], [upright, neutral])
        elbow = q.copy()
        elbow[2] = up3
        np.testing.assert_array_equal(elbow_first[row], [elbow, upright, neutral])
        shoulder = q.copy()
        shoulder[1] = up2
        np.testing.assert_array_equal(shoulder_first[row], [shoulder, upright, neutral])


@pytest.mark.parametrize(("speed", "accel"), [(0.5, 0.8), (100.0, 100.0)])
def test_a_plans_time_moves_through_its_vias_at_speeds_capped_by_the_model(speed, accel):
    q = np.array([[0.0, -1.6, 1.4, -1.2, 1.1, 0.4], [0.8, -1.2, 1.1, -1.0, 1.5, 0.9]])
    via = np.array([[0.4, -1.5707963, 0.0, -1.5707963, 0.0, 0.6]])
    plan = planning.Plan(q, (np.zeros((0, 6)), via))
    got = ordering.estimate(plan, UR10E, speed, accel, settle_s=0.25, readings=4, rate_hz=8.0)
    v = min(speed, UR10E.move_speed_cap_rad_s)
    a = min(accel, UR10E.move_accel_cap_rad_s2)
    path = np.vstack([q[0], via[0], q[1]])
    moves = float(timing.move_times(path[:-1], path[1:], v, a).sum())
    assert got.moves_s == pytest.approx(moves)
    assert (got.settle_s, got.readings_s) == (pytest.approx(0.5), pytest.approx(1.0))
    # The direct move would be shorter: the via is counted.
    assert got.moves_s > float(timing.move_times(q[:1], q[1:], v, a).sum())
    if speed > UR10E.move_speed_cap_rad_s:
        assert got.moves_s == pytest.approx(
            ordering.estimate(plan, UR10E, UR10E.move_speed_cap_rad_s,
                              UR10E.move_accel_cap_rad_s2, settle_s=0.25, readings=4,
                              rate_hz=8.0).moves_s
        )  # fmt: skip
