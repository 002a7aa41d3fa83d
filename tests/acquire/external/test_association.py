"""Stops matched to plan poses: skips, pauses, double and wrong stops, a poor tool guess."""

import numpy as np
import pytest

from calibrator.acquire.external import Assigned, Associator, Rejected, Stop
from calibrator.acquire.external.associate import RULE_STOPS, TOLERANCE_FACTOR, TOLERANCE_FLOOR_MM
from calibrator.acquire.external.registration import register
from calibrator.model import frames, kinematics
from calibrator.simulate import SimWorld, sample_joints

CELL = SimWorld.make("ur10e", 5)
NOISE_MM = 0.005  # a mean of 10 readings


def _plan(n=30, seed=1):
    rng = np.random.default_rng(seed)
    return sample_joints(CELL.model.joint_limits_rad * 0.8, n, rng)


def _true_points(q, cell=None):
    """True reflector points (tracker frame, mm) of joints ``q`` in ``cell`` (mdh, tool, base)."""
    mdh, tool, base = (CELL.true_mdh, CELL.flange2tool, CELL.base2tracker) if cell is None else cell
    return kinematics.forward(mdh, q, tool, base)[:, :3, 3]


def _cell(seed, scale=1.0, tool_mm=None):
    """A hidden cell: ``measure``'s simulated one, its arm errors scaled, its reflector moved."""
    world = SimWorld.make("ur10e", seed)
    mdh = world.model.mdh + scale * (world.true_mdh - world.model.mdh)
    tool = world.flange2tool
    if tool_mm is not None:
        tool = frames.transform(translation=tool_mm)
    return mdh, tool, world.base2tracker


def _run(
    plan, stop_joints, tool_guess=(0.0, 0.0, 100.0), tolerance=15.0, seed=0, cell=None, off=None
):
    """Decisions for stops at the true points of ``stop_joints`` (in time order).

    ``off``: {stop number: mm}, stops that far (random direction) from their true point.
    """
    rng = np.random.default_rng(seed)
    points = _true_points(np.asarray(stop_joints), cell)
    points += rng.normal(0, NOISE_MM, (len(stop_joints), 3))
    for k, mm in (off or {}).items():
        direction = rng.normal(size=3)
        points[k] += mm * direction / np.linalg.norm(direction)
    assoc = Associator(kinematics.forward(CELL.model.mdh, plan), tool_guess, tolerance)
    decisions = []
    for k, p in enumerate(points):
        decisions += assoc.add(Stop(k, float(k), p))
    decisions += assoc.finish()
    assigned = {d.stop.number: d.pose for d in decisions if isinstance(d, Assigned)}
    rejected = sorted(d.stop.number for d in decisions if isinstance(d, Rejected))
    assert len(assigned) + len(rejected) == len(points)  # every stop decided once
    _run.reasons = {d.stop.number: d.reason for d in decisions if isinstance(d, Rejected)}
    _run.tolerance = assoc.tolerance()
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


@pytest.mark.parametrize(("poses", "first"), [(8, 0), (5, 0), (14, 7)])
def test_a_plan_shorter_than_the_bootstrap_is_placed_as_its_stops_come(poses, first):
    """An 8-pose check (or a resumed run's last poses) is placed before any timeout:
    each pose as soon as the next stop (the move home) comes, none left for ``finish``."""
    plan = _plan(poses, seed=2)
    home = plan.mean(axis=0)
    points = _true_points(np.vstack([plan[first:], home[None]]))
    assoc = Associator(kinematics.forward(CELL.model.mdh, plan), (0.0, 0.0, 100.0), 15.0, first)
    decisions = []
    for k, p in enumerate(points):
        decisions += assoc.add(Stop(k, float(k), p))
    assigned = {d.stop.number: d.pose for d in decisions if isinstance(d, Assigned)}
    assert assigned == {k: first + k for k in range(poses - first)}
    assert [d.stop.number for d in decisions if isinstance(d, Rejected)] == [poses - first]
    assert assoc.finish() == []


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


# A stop that is not where its pose belongs (a controller that stopped short, a
# wrong point in the program, a bumped reflector) must never be recorded as that
# pose: it is held to the tolerance the registration's own misfits set.
@pytest.mark.parametrize(
    ("cell_seed", "scale", "wrong", "mm"),
    [
        (5, 1.0, 1, 9.8),  # the arm measure simulates: ~1.5 mm misfits
        (5, 1.0, 7, 9.8),
        (6, 1.0, 22, 8.0),
        (7, 0.3, 4, 4.0),  # an arm closer to nominal: a few mm stand out
        (8, 0.3, 7, 3.0),
        (9, 0.3, 33, 3.0),
        (10, 0.1, 2, 2.0),
    ],
)
def test_a_wrong_stop_is_rejected_named_and_its_pose_missing(cell_seed, scale, wrong, mm):
    plan = _plan(40, seed=cell_seed)
    cell = _cell(cell_seed, scale)
    assigned, rejected = _run(plan, plan, cell=cell, off={wrong: mm}, seed=cell_seed)
    assert rejected == [wrong], _run.reasons
    assert f"nearest is pose {wrong} at" in _run.reasons[wrong]
    assert assigned == {k: k for k in range(len(plan)) if k != wrong}
    assert _run.tolerance < mm  # tightened to the arm's misfits, well below the bound


@pytest.mark.parametrize(
    ("true_tool", "guess"),
    [
        ((11.3, -6.8, 96.2), (0.0, 0.0, 100.0)),  # 14 mm off, the default guess
        ((-9.0, 12.0, 118.0), (0.0, 0.0, 100.0)),  # 23 mm off
        ((20.0, 0.0, 100.0), (0.0, 0.0, 100.0)),  # 20 mm, sideways
        ((0.0, 0.0, 100.0), (-14.0, 8.0, 104.0)),  # a guess off the other way
    ],
)
@pytest.mark.parametrize("cell_seed", [11, 12])
def test_a_reflector_guess_far_off_keeps_every_good_stop(true_tool, guess, cell_seed):
    plan = _plan(40, seed=cell_seed)
    cell = _cell(cell_seed, 1.0, tool_mm=true_tool)
    # with a home stop first and one pose skipped, as a program runs
    run = [k for k in range(len(plan)) if k != 13]
    home = plan.mean(axis=0)
    assigned, rejected = _run(plan, [home, *plan[run]], tool_guess=guess, cell=cell)
    assert rejected == [0], _run.reasons
    assert assigned == {n + 1: k for n, k in enumerate(run)}


def test_the_tolerance_follows_the_arm_not_the_bound():
    """40-pose runs on arms 0.1 and 1 times as far off as measure simulates them."""
    tolerances = {0.1: [], 1.0: []}
    for seed in range(1, 9):
        plan = _plan(40, seed=seed)
        for scale, out in tolerances.items():
            _run(plan, plan, cell=_cell(seed, scale))
            out.append(_run.tolerance)
    print({scale: (round(min(t), 2), round(max(t), 2)) for scale, t in tolerances.items()})
    assert all(TOLERANCE_FLOOR_MM <= t < 2.0 for t in tolerances[0.1])
    assert all(3.0 < t < 10.0 for t in tolerances[1.0])


def test_a_good_stop_lands_within_the_tolerance_factor_of_its_prediction():
    """The factor's measurement: prediction misfit over the LOO RMS, from RULE_STOPS stops on."""
    ratios = []
    for seed in range(1, 13):  # arms 0.1 to 2 times measure's simulated errors, guess 14 mm off
        plan = _plan(40, seed=seed)
        cell = _cell(seed, (0.1, 0.5, 1.0, 2.0)[seed % 4], tool_mm=(11.3, -6.8, 96.2))
        points = _true_points(plan, cell)
        flange = kinematics.forward(CELL.model.mdh, plan)
        for n in range(RULE_STOPS, len(plan), 2):
            reg = register(flange[:n], points[:n], (0.0, 0.0, 100.0))
            miss = np.linalg.norm(reg.predict(flange[n : n + 1])[0] - points[n])
            ratios.append(miss / reg.loo_rms_mm())
    print(f"largest {max(ratios):.2f}, 99 % {np.percentile(ratios, 99):.2f} of {len(ratios)}")
    assert max(ratios) < TOLERANCE_FACTOR


def test_a_reflector_beyond_its_bound_places_no_stop_and_says_what_to_check():
    """45 mm from the guess is no plausible guess error: nothing is recorded, nothing wrongly."""
    plan = _plan(30, seed=4)
    cell = _cell(4, 1.0, tool_mm=(45.0, 0.0, 100.0))
    assigned, rejected = _run(plan, plan, cell=cell)
    assert assigned == {} and rejected == list(range(len(plan)))
    assert all("--tool" in why for why in _run.reasons.values()), _run.reasons
