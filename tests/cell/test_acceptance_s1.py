"""S1: 60-pose UR10e plans from three tracker positions, judged by an independent arm model.

The judge below shares no code with ``calibrator``: its own standard-DH
forward kinematics from UR's published UR10e table, and points on the real
arm (joint centres, the link bodies offset along the shoulder axis as UR's
drawings place them, the tool). It refuses a pose with any such point below
the mounting plane or inside the base, and a move (the joint-space line of
moveJ, 0.25 deg steps, vias included as rows) that does either on the way.
"""

import math

import numpy as np
import pytest

from calibrator import cell, planning, robots

# UR10e, UR's published DH table (standard DH): d, a, alpha.
_D = (180.7, 0.0, 0.0, 174.15, 119.85, 116.55)
_A = (0.0, -612.7, -571.55, 0.0, 0.0, 0.0)
_ALPHA = (math.pi / 2, 0.0, 0.0, math.pi / 2, -math.pi / 2, 0.0)
TOOL = np.array([0.0, 0.0, 100.0])
BASE_RADIUS, BASE_TOP = 95.0, 180.7
BODY = 45.0  # half the smallest link diameter: a point closer than this to the plane is a hit


def _judge_points(q):
    """Points on the arm, (M, P, 3) mm: joint centres, link bodies, the tool."""
    q = np.atleast_2d(q)
    t = np.broadcast_to(np.eye(4), (len(q), 4, 4)).copy()
    frames = [t.copy()]
    for i in range(6):
        th = q[:, i]
        ct, st = np.cos(th), np.sin(th)
        ca, sa = math.cos(_ALPHA[i]), math.sin(_ALPHA[i])
        a = np.zeros((len(q), 4, 4))
        a[:, 0, 0], a[:, 0, 1], a[:, 0, 2], a[:, 0, 3] = ct, -st * ca, st * sa, _A[i] * ct
        a[:, 1, 0], a[:, 1, 1], a[:, 1, 2], a[:, 1, 3] = st, ct * ca, -ct * sa, _A[i] * st
        a[:, 2, 1], a[:, 2, 2], a[:, 2, 3] = sa, ca, _D[i]
        a[:, 3, 3] = 1.0
        t = t @ a
        frames.append(t.copy())
    pts = []
    for k in (2, 3, 4, 5, 6):  # elbow, wrist 1, wrist 2, wrist 3, flange
        pts.append(frames[k][:, :3, 3])
    # The upper arm and forearm tubes lie 176 and 39 mm along the shoulder axis.
    axis = frames[1][:, :3, 2]
    for s in np.linspace(0.0, 1.0, 5):
        pts.append(frames[1][:, :3, 3] * (1 - s) + frames[2][:, :3, 3] * s + 176.0 * axis)
        pts.append(frames[2][:, :3, 3] * (1 - s) + frames[3][:, :3, 3] * s + 39.0 * axis)
    pts.append(frames[2][:, :3, 3] + 176.0 * axis)  # elbow housing, outer end
    pts.append(frames[6][:, :3, :3] @ TOOL + frames[6][:, :3, 3])
    return np.stack(pts, axis=1)


def _bad(q):
    """Per row of q (M, 6): some arm point under the plane or inside the base."""
    p = _judge_points(q)
    low = (p[..., 2] < BODY).any(axis=1)
    inside = ((np.hypot(p[..., 0], p[..., 1]) < BASE_RADIUS + BODY) & (p[..., 2] < BASE_TOP)).any(
        axis=1
    )
    return low | inside


def _bad_moves(path):
    bad = []
    for i in range(len(path) - 1):
        steps = max(2, int(np.ceil(np.abs(path[i + 1] - path[i]).max() / np.radians(0.25))) + 1)
        if _bad(np.linspace(path[i], path[i + 1], steps)).any():
            bad.append(i)
    return bad


def test_the_judge_sees_the_issues_plans_fail():
    # The old planner's kind of pose (elbow 420 mm under the plane) and the wrist's long way round.
    assert _bad(np.radians([[-61, 79, -159, -34, 159, -73]])).all()
    qa, qb = np.radians([0.0, 0.0, 0.0, -170.0, 90.0, 0.0]), np.radians([0, 0, 0, 170.0, 90, 0])
    assert not _bad(np.array([qa, qb])).any() and _bad_moves(np.array([qa, qb])) == [0]
    # And a plan made as the old planner did (poses inside the joint margin that
    # face the issue's tracker position, nothing more) fails it.
    model = robots.get("ur10e")
    where = cell.Cell(tracker_at_mm=(2500.0, 400.0, 300.0))
    chk = cell.checker(cell.arm_geometry(model.name, model.mdh, TOOL), where)
    pool = planning.sample(planning.joint_box(model.joint_limits_rad, np.radians(5)), 4000)
    old = pool[~cell.checks.aim_faults(chk, pool)[:, 1]][:60]
    assert len(old) == 60
    assert _bad(old).sum() > 5 and len(_bad_moves(old)) > 10


@pytest.mark.parametrize("tracker_at", [(2500, 400, 300), (0, 2500, 500), (-2000, -1500, 800)])
def test_s1_60_pose_plans_have_no_bad_pose_and_no_bad_move(tracker_at):
    model = robots.get("ur10e")
    made = planning.make_checked(model, 60, cell.Cell(tracker_at_mm=tracker_at), TOOL)
    path = made.plan.path_rad
    assert len(made.plan.q_rad) == 60
    assert not _bad(path).any()
    assert _bad_moves(path) == []
