"""Ordering (calibrator/planning/ordering.py) where the way back home must be rotated.

Four poses of a UR10e in a cell with a crate in front of it: two low
(forearm reaching out at joint 1 = -60 and +60 deg) and two high (the arm
upright over them). Low to high and high to high are safe; low to low sweeps
through the crate. The short order visits low, high, high, low: its closing
move (the last pose back to the first, a program's way home) is the one
through the crate. The planner starts the cycle after its longest safe move
instead, so the way home is safe and the move through the crate becomes an
inner one, made with vias over the top.
"""

from __future__ import annotations

import numpy as np
import pytest

from calibrator import cell as cells
from calibrator import planning, robots
from calibrator.planning import ordering
from calibrator.planning.sampling import joint_box

UR10E = robots.get("ur10e")
#: The joint box the planner's vias keep within (its default 5-degree margin).
BOX = joint_box(UR10E.joint_limits_rad, np.radians(5.0))
TOOL_MM = (0.0, 0.0, 100.0)
LOW = [-0.7, 1.0, -1.87, -1.5708, 0.0]
HIGH = [-1.5708, 0.2, -0.2, -1.5708, 0.0]
SIDE = np.radians(60.0)
#: Low left, high left, high right, low right.
POSES = np.array([[-SIDE, *LOW], [-SIDE, *HIGH], [SIDE, *HIGH], [SIDE, *LOW]])
CELL = cells.Cell(boxes=(cells.Box("crate", (-1300.0, -300.0, 0.0), (-600.0, 300.0, 700.0)),))


@pytest.fixture
def chk():
    return cells.checker(cells.arm_geometry(UR10E.name, UR10E.mdh, TOOL_MM), CELL)


def _unsafe(chk, a, b):
    return bool(cells.motion_faults(chk, np.atleast_2d(a), np.atleast_2d(b)).any())


def test_the_cell_makes_only_the_low_to_low_moves_unsafe(chk):
    """The premise: every pose is safe; low to low (and the diagonals) hit the crate."""
    assert not cells.checks.collision_faults(chk, POSES).any()
    unsafe = {(a, b) for a in range(4) for b in range(a + 1, 4) if _unsafe(chk, POSES[a], POSES[b])}
    assert unsafe == {(0, 3), (0, 2), (1, 3)}
    # The shortest order is the one whose closing move is unsafe.
    order = cells.order_poses(cells.time_matrix(POSES, 1.0, 2.0))
    assert {int(order[0]), int(order[-1])} == {0, 3}


def test_the_cycle_starts_after_its_longest_safe_move_and_goes_home_safely(chk):
    ordered = ordering.order_joined(chk, POSES, BOX, 1.0, 2.0)
    assert ordered.unjoined == ()
    plan = ordered.plan
    rows = [int(np.flatnonzero(np.all(np.isclose(POSES, q), axis=1))[0]) for q in plan.q_rad]
    assert sorted(rows) == [0, 1, 2, 3]
    # The closing move is high to high (the longest safe move: joint 1 turns 120 deg).
    assert {rows[0], rows[-1]} == {1, 2}, rows
    assert not _unsafe(chk, plan.q_rad[-1], plan.q_rad[0])
    # Every move of the path, vias included, is safe; the old closing move got vias.
    path = plan.path_rad
    assert not cells.motion_faults(chk, path[:-1], path[1:]).any()
    assert plan.n_vias > 0
    planning.check_plan(plan, UR10E, CELL, TOOL_MM, home_rad=plan.q_rad[0])


def test_a_safe_closing_move_leaves_the_order_alone(chk):
    verdict: dict = {}
    order = np.array([1, 0, 3, 2])  # high-low-low-high: the closing move 2 -> 1 is safe
    times = cells.time_matrix(POSES, 1.0, 2.0)
    edges = list(zip(order[:-1].tolist(), order[1:].tolist(), strict=True))
    for e, f in zip(
        edges,
        cells.motion_faults(chk, POSES[[a for a, _ in edges]], POSES[[b for _, b in edges]]),
        strict=True,
    ):
        verdict[e] = verdict[e[::-1]] = f
    out = ordering._close_safely(ordering.MoveVerdicts(chk, BOX), POSES, order, times, verdict)
    np.testing.assert_array_equal(out, order)
    assert not verdict[(2, 1)].any()  # the closing move's verdict was recorded


def test_an_unsafe_closing_move_is_rotated_to_the_longest_safe_one(chk):
    verdict: dict = {}
    order = np.array([0, 1, 2, 3])
    times = cells.time_matrix(POSES, 1.0, 2.0)
    edges = [(0, 1), (1, 2), (2, 3)]
    for e, f in zip(edges, cells.motion_faults(chk, POSES[[0, 1, 2]], POSES[[1, 2, 3]]),
                    strict=True):  # fmt: skip
        verdict[e] = verdict[e[::-1]] = f
    out = ordering._close_safely(ordering.MoveVerdicts(chk, BOX), POSES, order, times, verdict)
    np.testing.assert_array_equal(out, [2, 3, 0, 1])
    assert verdict[(3, 0)].any() and verdict[(0, 3)].any()


def test_in_a_five_pose_cycle_the_way_home_is_the_longest_safe_move(chk):
    """An odd cycle: only one rotation puts the longest safe move last-to-first."""
    poses = np.vstack([POSES, [0.0, *HIGH]])  # a fifth pose: upright, between the others
    order = np.array([0, 1, 4, 2, 3])
    times = cells.time_matrix(poses, 1.0, 2.0)
    edges = list(zip(order[:-1].tolist(), order[1:].tolist(), strict=True))
    faults = cells.motion_faults(chk, poses[order[:-1]], poses[order[1:]])
    verdict = {}
    for e, f in zip(edges, faults, strict=True):
        verdict[e] = verdict[e[::-1]] = f
    assert not faults.any()  # every inner move is safe, the closing 3 -> 0 is not
    out = ordering._close_safely(ordering.MoveVerdicts(chk, BOX), poses, order, times, verdict)
    longest = max(range(len(edges)), key=lambda k: times[edges[k]])
    a, b = edges[longest]
    assert (int(out[-1]), int(out[0])) == (a, b)
    assert sorted(out.tolist()) == [0, 1, 2, 3, 4]
    # Still the same cycle, started elsewhere.
    start = order.tolist().index(int(out[0]))
    assert out.tolist() == order.tolist()[start:] + order.tolist()[:start]
    assert not _unsafe(chk, poses[out[-1]], poses[out[0]])
