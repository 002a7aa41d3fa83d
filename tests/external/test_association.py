"""Stops matched to plan poses: skipped poses, pauses, double stops and a poor tool guess."""

import numpy as np
import pytest

from calibrator import kinematics
from calibrator.simulate import SimWorld, sample_joints
from drivers.robot.external import Assigned, Associator, Rejected, Stop

CELL = SimWorld.make("ur10e", 5)
NOISE_MM = 0.005  # a mean of 10 readings


def _plan(n=30, seed=1):
    rng = np.random.default_rng(seed)
    return sample_joints(CELL.model.joint_limits_rad * 0.8, n, rng)


def _true_points(q):
    return kinematics.forward(CELL.true_mdh, q, CELL.flange2tool, CELL.base2tracker)[:, :3, 3]


def _run(plan, stop_joints, tool_guess=(0.0, 0.0, 100.0), tolerance=15.0, seed=0):
    """Decisions for stops at the true points of ``stop_joints`` (in time order)."""
    rng = np.random.default_rng(seed)
    points = _true_points(np.asarray(stop_joints)) + rng.normal(0, NOISE_MM, (len(stop_joints), 3))
    assoc = Associator(kinematics.forward(CELL.model.mdh, plan), tool_guess, tolerance)
    decisions = []
    for k, p in enumerate(points):
        decisions += assoc.add(Stop(k, float(k), p))
    decisions += assoc.finish()
    assigned = {d.stop.number: d.pose for d in decisions if isinstance(d, Assigned)}
    rejected = sorted(d.stop.number for d in decisions if isinstance(d, Rejected))
    assert len(assigned) + len(rejected) == len(points)  # every stop decided once
    return assigned, rejected


def test_stops_in_order_are_their_poses():
    plan = _plan()
    assigned, rejected = _run(plan, plan)
    assert assigned == {k: k for k in range(len(plan))} and rejected == []


@pytest.mark.parametrize("skipped", [[1], [7], [7, 8], [12, 20], [len(_plan()) - 1]])
def test_skipped_poses_keep_every_other_stop_on_its_own_pose(skipped):
    plan = _plan()
    run = [k for k in range(len(plan)) if k not in skipped]
    assigned, rejected = _run(plan, plan[run])
    assert assigned == dict(enumerate(run)) and rejected == []


def test_a_pause_midway_is_rejected_not_recorded():
    plan = _plan()
    midway = 0.5 * (plan[10] + plan[11])
    stops = [*plan[:11], midway, *plan[11:]]
    assigned, rejected = _run(plan, stops)
    assert rejected == [11]
    assert assigned == {k: (k if k < 11 else k - 1) for k in range(len(stops)) if k != 11}


def test_stops_before_the_plan_starts_are_rejected_in_the_bootstrap():
    plan = _plan()
    home, early = plan.mean(axis=0), 0.3 * plan[0] + 0.7 * plan[1]
    assigned, rejected = _run(plan, [home, plan[0], early, *plan[1:]])
    assert rejected == [0, 2]
    assert assigned[1] == 0 and assigned[3] == 1 and assigned[len(plan) + 1] == len(plan) - 1


def _short_of(plan, pose, mm):
    """Joints on the way from ``pose - 1`` to ``pose``, about ``mm`` before arriving."""
    step = plan[pose - 1] - plan[pose]
    full = np.linalg.norm(_true_points(plan[pose - 1 : pose]) - _true_points(plan[pose : pose + 1]))
    return plan[pose] + (mm / full) * step


def test_a_pause_short_of_a_pose_loses_to_the_real_stop():
    plan = _plan()
    almost = _short_of(plan, 15, 9.0)
    assigned, rejected = _run(plan, [*plan[:15], almost, *plan[15:]])
    assert rejected == [15]  # the real stop (number 16) is the pose
    assert assigned[16] == 15 and 15 not in assigned


def test_two_stops_too_close_to_tell_apart_record_neither():
    plan = _plan()
    almost = _short_of(plan, 15, 1.5)  # within what the nominal arm can predict
    assigned, rejected = _run(plan, [*plan[:15], almost, *plan[15:]])
    assert rejected == [15, 16]  # pose 15 goes missing rather than maybe wrong
    assert 15 not in assigned.values() and assigned[17] == 16


def test_a_tool_guess_millimetres_off_is_re_estimated():
    plan = _plan(40)
    assigned, rejected = _run(plan, plan, tool_guess=(4.0, -3.0, 104.0))
    assert assigned == {k: k for k in range(40)} and rejected == []


def test_no_stop_is_ever_assigned_to_a_pose_it_is_not():
    """Random programs: skips, pauses and extra stops; every assignment is right or absent."""
    plan = _plan(35, seed=3)
    rng = np.random.default_rng(11)
    for trial in range(15):
        stops, truth = [], []
        for k in range(len(plan)):
            if rng.random() < 0.1:
                continue  # skipped
            if rng.random() < 0.1:
                stops.append(plan[k - 1] + rng.uniform(0.2, 0.8) * (plan[k] - plan[k - 1]))
                truth.append(None)  # a pause on the way
            stops.append(plan[k])
            truth.append(k)
        assigned, _ = _run(plan, stops, seed=trial)
        for number, pose in assigned.items():
            assert truth[number] == pose, (trial, number)
        recorded = {truth[n] for n in assigned}
        expected = {t for t in truth if t is not None}
        assert len(expected - recorded) <= 1, trial  # at most the bootstrap's ambiguity
