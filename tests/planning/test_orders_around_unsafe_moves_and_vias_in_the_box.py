"""Ordering (calibrator/planning/ordering.py) in cells that reach its other cases.

The cells of ``test_closing_move.py`` and ``test_joined.py`` never need the
ordering's own way round an unsafe move (ordering again without it), never
order poses whose every order crosses the obstacle, and never put a pose
near a joint limit the vias keep away from. Here:

- a low crate between two low poses: the short order's inner move between
  them sweeps through it; ordered again without that move, a cycle of safe
  direct moves exists and the plan has no vias;
- eight low poses, four either side of a tall crate: every order crosses it,
  so the ordering gives up after its eighth order and puts vias over the top;
- a pose whose wrist (joint 6) sits in the 5-degree margin of its limit: no
  via may leave the joint box, so no way over the top joins it;
- an arm whose upright elbow and neutral wrist lie outside its box: the ways
  up hold each joint at its own limit.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from calibrator import cell as cells
from calibrator import robots
from calibrator.planning import ordering
from calibrator.planning.sampling import joint_box

UR10E = robots.get("ur10e")
MARGIN = np.radians(5.0)
BOX = joint_box(UR10E.joint_limits_rad, MARGIN)
TOOL_MM = (0.0, 0.0, 100.0)
#: Joints 2 to 6: forearm reaching out low, and the arm high over it (test_closing_move.py).
LOW = [-0.7, 1.0, -1.87, -1.5708, 0.0]
HIGH = [-1.5708, 0.2, -0.2, -1.5708, 0.0]


def _checker(top_mm: float):
    crate = cells.Box("crate", (-1300.0, -200.0, 0.0), (-600.0, 200.0, top_mm))
    return cells.checker(
        cells.arm_geometry(UR10E.name, UR10E.mdh, TOOL_MM), cells.Cell(boxes=(crate,))
    )


def _unsafe(chk, a, b) -> bool:
    return bool(cells.motion_faults(chk, np.atleast_2d(a), np.atleast_2d(b)).any())


def _rows(poses, q_rad):
    return [int(np.flatnonzero(np.all(np.isclose(poses, q), axis=1))[0]) for q in q_rad]


#: Low at joint 1 = -40 and +40 deg, high at -60 and +60 deg.
FOUR = np.array(
    [
        [-np.radians(40), *LOW],
        [np.radians(40), *LOW],
        [-np.radians(60), *HIGH],
        [np.radians(60), *HIGH],
    ]
)


def test_a_short_orders_unsafe_inner_move_is_ordered_round_without_vias():
    chk = _checker(300.0)  # a crate 300 mm tall: only the low-to-low sweep touches it
    unsafe = {(a, b) for a in range(4) for b in range(a + 1, 4) if _unsafe(chk, FOUR[a], FOUR[b])}
    assert unsafe == {(0, 1)}
    # The premise: the shortest order moves low to low inside, not at its ends.
    first = cells.order_poses(cells.time_matrix(FOUR, 1.0, 2.0)).tolist()
    assert abs(first.index(0) - first.index(1)) == 1 and {first[0], first[-1]} != {0, 1}
    ordered = ordering.order_joined(chk, FOUR, BOX, 1.0, 2.0)
    assert ordered.unjoined == ()
    rows = _rows(FOUR, ordered.plan.q_rad)
    assert sorted(rows) == [0, 1, 2, 3] and rows == ordered.order.tolist()
    # Ordered again without the low-to-low move: every move direct, the way home too.
    assert ordered.plan.n_vias == 0
    cycle = [*rows, rows[0]]
    assert all(
        not _unsafe(chk, FOUR[a], FOUR[b]) for a, b in zip(cycle[:-1], cycle[1:], strict=True)
    )


def test_when_every_order_crosses_the_obstacle_the_ordering_stops_and_goes_over_the_top():
    chk = _checker(700.0)
    # Four low poses either side of the crate: every move across it is unsafe, so each
    # order tried has one; the ordering stops after its eighth and makes vias.
    angles = np.radians([50.0, 65.0, 80.0, 95.0])
    poses = np.array([[s * a, *LOW] for s in (-1, 1) for a in angles])
    ordered = ordering.order_joined(chk, poses, BOX, 1.0, 2.0)
    assert ordered.unjoined == ()
    assert sorted(ordered.order.tolist()) == list(range(8))
    plan = ordered.plan
    side = np.sign(plan.q_rad[:, 0])
    crossings = int((side[1:] != side[:-1]).sum())
    # An open path crosses once at least; the way home crosses back unless the path
    # crossed twice. Every crossing, and nothing else, has its vias over the top.
    assert crossings in (1, 2) and (side[0] == side[-1]) == (crossings == 2)
    assert plan.n_vias > 0
    for k, via in enumerate(plan.via_rad):
        crossed = k > 0 and side[k] != side[k - 1]
        assert (len(via) > 0) == crossed, k
    path = plan.path_rad
    assert not cells.motion_faults(chk, path[:-1], path[1:]).any()
    assert np.all((path >= BOX[:, 0] - 1e-12) & (path <= BOX[:, 1] + 1e-12))
    assert not _unsafe(chk, plan.q_rad[-1], plan.q_rad[0])


def _at_wrist_limit(q):
    """``q`` with joint 6 two degrees inside its upper limit: within the limits, outside the box."""
    out = np.array(q, dtype=float)
    out[5] = UR10E.joint_limits_rad[5, 1] - np.radians(2.0)
    assert out[5] > BOX[5, 1]
    return out


def test_the_vias_over_the_top_are_the_way_up_then_the_other_poses_way_up_reversed():
    chk = _checker(700.0)
    qa, qb = np.array([-np.radians(60), *LOW]), np.array([np.radians(60), *LOW])
    assert _unsafe(chk, qa, qb)
    via = ordering._upright_vias(chk, qa, qb, BOX)
    assert via is not None and via.shape == (4, 6)
    up2, up3 = UR10E.upright_rad
    w4, w5 = UR10E.neutral_wrist_rad
    # Up from qa (upright, then the wrist neutral), across, and down to qb the same way.
    np.testing.assert_allclose(via[0], [qa[0], up2, up3, *qa[3:]])
    np.testing.assert_allclose(via[1], [qa[0], up2, up3, w4, w5, qa[5]])
    np.testing.assert_allclose(via[2], [qb[0], up2, up3, w4, w5, qb[5]])
    np.testing.assert_allclose(via[3], [qb[0], up2, up3, *qb[3:]])
    path = np.vstack([qa, via, qb])
    assert not cells.motion_faults(chk, path[:-1], path[1:]).any()


def test_no_via_leaves_the_joint_box_so_a_pose_at_its_wrist_limit_is_not_joined_over_the_top():
    chk = _checker(700.0)
    qa = np.array([-np.radians(60), *LOW])
    qb = np.array([np.radians(60), *LOW])
    edge = _at_wrist_limit(qb)
    assert _unsafe(chk, qa, edge)
    # Every way up keeps joint 6 where it is: each via of edge's would leave the box.
    assert ordering._upright_vias(chk, qa, edge, BOX) is None
    assert ordering._upright_vias(chk, edge, qa, BOX) is None
    verdicts = ordering.MoveVerdicts(chk, BOX)
    # Judged pose by pose: the one in the margin only, not both.
    assert verdicts.joinable(qa, np.array([qb, edge])).tolist() == [True, False]
    assert verdicts.joinable(edge, qa[None]).tolist() == [False]
    # And the ordering says so: the move stays unjoined, named with its reason.
    ordered = ordering.order_joined(chk, np.array([qa, edge]), BOX, 1.0, 2.0)
    assert {(a, b) for a, b, _ in ordered.unjoined} == {(0, 1), (1, 0)}
    assert all(reason == "obstacle" for _, _, reason in ordered.unjoined)


@pytest.fixture
def cramped():
    """A UR10e whose elbow cannot stand straight and whose wrist cannot reach neutral.

    Joint 3 from -1 deg (upright, 0, is within 5 deg of it, as the IRB 2400's
    joint 3 at its -60 deg limit) and joint 4 from -92 deg (neutral, -90 deg,
    within 5 deg of it); joints 2 and 5 as shipped.
    """
    limits = np.array(UR10E.joint_limits_rad)
    limits[2] = np.radians([-1.0, 180.0])
    limits[3] = np.radians([-92.0, 180.0])
    arm = dataclasses.replace(UR10E, joint_limits_rad=limits)
    return arm, joint_box(limits, MARGIN)


def test_the_ways_up_hold_each_joint_at_its_own_box_when_upright_is_outside_it(cramped):
    arm, box = cramped
    chk = cells.checker(cells.arm_geometry(arm.name, arm.mdh, TOOL_MM), cells.Cell())
    q = np.array([[0.3, *HIGH], [-0.4, *LOW]])
    q[:, 3] = np.radians(-30.0)
    ways = ordering._rise_paths(chk, q, box)
    assert [w.shape for w in ways] == [(2, 2, 6), (2, 3, 6), (2, 3, 6)]
    # Joint 2 upright as the arm's (-90 deg, inside its box); joint 3 held 5 deg off its
    # -1 deg limit; joint 4 held 5 deg off its -92 deg limit; joint 5 neutral (0, inside).
    up2 = arm.upright_rad[0]
    assert box[1, 0] < up2 < box[1, 1]
    for way in ways:
        upright, neutral = way[:, -2], way[:, -1]
        np.testing.assert_allclose(upright[:, 1:3], [[up2, np.radians(4.0)]] * 2)
        np.testing.assert_allclose(
            neutral[:, 1:5], [[up2, np.radians(4.0), np.radians(-87.0), 0.0]] * 2
        )
        np.testing.assert_allclose(neutral[:, [0, 5]], q[:, [0, 5]])
        assert np.all((way >= box[:, 0] - 1e-12) & (way <= box[:, 1] + 1e-12))
    # Without a box the ways up are the arm's own upright and neutral.
    bare = ordering._rise_paths(chk, q)[0][:, -1]
    np.testing.assert_allclose(bare[:, 1:5], [[up2, 0.0, -np.pi / 2, 0.0]] * 2, atol=1e-12)
    # The vias over the top of this arm keep within its box too.
    via = ordering._upright_vias(chk, q[0], q[1], box)
    assert via is not None
    assert np.all((via >= box[:, 0] - 1e-12) & (via <= box[:, 1] + 1e-12))


def test_a_shoulder_that_cannot_quite_stand_upright_is_held_at_its_own_upper_end():
    # Joint 2 up to -88 deg: upright (-90 deg) lies within the limits, 2 deg inside the
    # margin; joint 3's box (to 175 deg) must not be the one that holds it.
    limits = np.array(UR10E.joint_limits_rad)
    limits[1] = np.radians([-180.0, -88.0])
    upright = dict(UR10E.configurations)["upright"]
    arm = dataclasses.replace(
        UR10E, joint_limits_rad=limits, configurations={"home": upright, "upright": upright}
    )
    box = joint_box(limits, MARGIN)
    chk = cells.checker(cells.arm_geometry(arm.name, arm.mdh, TOOL_MM), cells.Cell())
    q = np.array([[0.3, np.radians(-120.0), 0.5, -1.0, 0.4, 0.2]])
    for way in ordering._rise_paths(chk, q, box):
        np.testing.assert_allclose(way[0, -1, 1:3], np.radians([-93.0, 0.0]), atol=1e-12)
