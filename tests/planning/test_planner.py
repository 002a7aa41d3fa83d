"""The cell-aware planner (calibrator/planning/planner.py).

Checked candidates, distinct poses, the margin, the aim, the choice among candidates.
"""

import numpy as np
import pytest
from plan_kit import CHECKED_PLAN_TRACKER_MM

from calibrator import cell, planning, robots, session
from calibrator.identify import pipeline
from calibrator.model import DEFAULT_TOOL_MM, frames, kinematics, measurement
from calibrator.simulate import SIM_TRACKER_AT_MM, SimWorld

UR10E = robots.get("ur10e")
TOOL = frames.transform(translation=[0.0, 0.0, 100.0])
TOOL_MM = (0.0, 0.0, 100.0)
SIM_TOOL_MM = DEFAULT_TOOL_MM
SIM_TOOL = frames.transform(translation=DEFAULT_TOOL_MM)


def test_plan_from_all_identical_candidates_is_refused_not_reported_healthy():
    # Twelve copies of one good pose used to come out as a "d-optimal" plan with a
    # healthy-looking smallest singular value (the free set was pruned to what one
    # pose can see).
    pose = np.radians([0.0, -90.0, 60.0, -150.0, -90.0, 0.0])
    with pytest.raises(planning.PlanError, match=r"only 1 of 40 candidates .*duplicate 39"):
        planning.make_checked(UR10E, 12, cell.Cell(), TOOL_MM, candidates=np.tile(pose, (40, 1)))


def test_plan_too_few_distinct_poses_for_the_parameters_is_refused():
    good = planning.make_checked(
        UR10E, 30, cell.Cell(tracker_at_mm=(2500.0, 400.0, 300.0)), TOOL_MM
    )
    few = good.plan.q_rad[:3]
    with pytest.raises(planning.PlanError, match=r"determine only \d+ of the \d+ parameters"):
        planning.make_checked(UR10E, 3, cell.Cell(), TOOL_MM, candidates=few, selection="first")


def test_candidates_failing_checks_are_dropped_with_counts_per_reason():
    made = planning.make_checked(
        UR10E, 20, cell.Cell(tracker_at_mm=(2500.0, 400.0, 300.0)), TOOL_MM, n_candidates=6000
    )
    assert made.candidates == 6000
    assert made.dropped["acceptance angle"] > 3000
    assert made.dropped["below mounting plane"] > 0 and made.dropped["self collision"] > 0
    assert sum(made.dropped.values()) + 20 <= 6000
    chk = cell.checker(cell.arm_geometry("ur10e", UR10E.mdh, TOOL_MM), made_cell())
    assert not cell.pose_faults(chk, made.plan.q_rad).any()
    planning.check_plan(made.plan, UR10E, made_cell(), TOOL_MM)
    # The order is time-optimised: never slower than the selection order.
    assert made.ordered_time.moves_s < made.selection_time.moves_s


def made_cell():
    return cell.Cell(tracker_at_mm=(2500.0, 400.0, 300.0))


def test_a_tracker_inside_the_reach_is_refused():
    with pytest.raises(cell.CellError, match="reach envelope"):
        planning.make_checked(UR10E, 20, cell.Cell(tracker_at_mm=(300.0, 0.0, 0.0)), TOOL_MM)


def facing(q, tracker_at):
    """Angle (rad) between the tool's z axis and the line to the tracker, and the tool's z, mm."""
    tool = kinematics.chain(UR10E.mdh, q) @ TOOL
    to_tracker = tracker_at - tool[:, :3, 3]
    cos = np.einsum("nj,nj->n", tool[:, :3, 2], to_tracker) / np.linalg.norm(to_tracker, axis=1)
    return np.arccos(np.clip(cos, -1, 1)), tool[:, 2, 3]


def test_a_made_plan_keeps_its_margin_faces_the_tracker_and_stays_above_the_plane():
    where = cell.Cell(tracker_at_mm=tuple(SIM_TRACKER_AT_MM), acceptance_deg=25.0)
    made = planning.make_checked(UR10E, 25, where, TOOL_MM, margin_rad=np.radians(10), seed=4)
    q = made.plan.q_rad
    assert q.shape == (25, 6)
    box = planning.joint_box(UR10E.joint_limits_rad, np.radians(10))
    for rows in (q, made.plan.path_rad):
        assert np.all(rows >= box[:, 0]) and np.all(rows <= box[:, 1])
    assert np.all(np.abs(q) <= np.pi - np.radians(10) + 1e-12)
    angle, height = facing(q, SIM_TRACKER_AT_MM)
    assert np.degrees(angle).max() <= 25.0
    # The tool point and the wrist's origins clear the mounting plane (z = 0) by the margin.
    _, link = kinematics.chain(UR10E.mdh, q, all_frames=True)
    assert height.min() >= where.margin_mm and link[:, 4:, 2, 3].min() >= where.margin_mm
    # The checks do bite: sampled candidates break the aim and the plane.
    assert made.dropped["acceptance angle"] > 0 and made.dropped["below mounting plane"] > 0


def test_by_default_the_planner_keeps_five_degrees_from_the_limits_and_thirty_of_acceptance():
    import inspect

    default = inspect.signature(planning.make_checked).parameters["margin_rad"].default
    assert default == pytest.approx(np.radians(5))
    assert cell.Cell().acceptance_deg == 30.0 and cell.Cell().tracker_at_mm is None


def test_given_candidates_outside_the_margin_are_dropped_and_counted(checked_plan):
    good = checked_plan.q_rad
    outside = good[:1].copy()
    outside[0, 1] = np.pi  # within the limits, not within the margin
    given = np.vstack([outside, good])
    where = cell.Cell(tracker_at_mm=CHECKED_PLAN_TRACKER_MM)
    made = planning.make_checked(UR10E, 10, where, TOOL_MM, candidates=given, selection="first")
    assert sorted(map(tuple, made.plan.q_rad)) == sorted(map(tuple, good))
    assert made.candidates == 11 and made.dropped["outside joint limits less margin"] == 1
    with pytest.raises(planning.PlanError, match="^only 10 of 11 candidates pass .*; 11 asked"):
        planning.make_checked(UR10E, 11, where, TOOL_MM, candidates=given, selection="first")


def test_candidates_exactly_on_the_margin_are_kept(checked_plan):
    q = checked_plan.q_rad
    # The margin that puts the box's edge exactly on the largest angle of the plan.
    edge = np.abs(q).max()
    margin = np.pi - edge
    while np.pi - margin > edge:
        margin = np.nextafter(margin, 1.0)
    while np.pi - margin < edge:
        margin = np.nextafter(margin, 0.0)
    box = planning.joint_box(UR10E.joint_limits_rad, margin)
    assert np.isin(edge, np.abs(box))
    where = cell.Cell(tracker_at_mm=CHECKED_PLAN_TRACKER_MM)
    made = planning.make_checked(
        UR10E, 10, where, TOOL_MM, margin_rad=margin, candidates=q, selection="first"
    )
    assert made.dropped["outside joint limits less margin"] == 0
    assert sorted(map(tuple, made.plan.q_rad)) == sorted(map(tuple, q))


def test_selection_first_random_and_d_optimal_choose_among_the_given_candidates():
    pool = planning.sample(planning.joint_box(UR10E.joint_limits_rad, np.radians(5)), 4000,
                           "halton", 4)  # fmt: skip
    where = cell.Cell(tracker_at_mm=tuple(SIM_TRACKER_AT_MM))

    def made(selection, seed=4):
        return planning.make_checked(
            UR10E, 12, where, TOOL_MM, candidates=pool, selection=selection, seed=seed
        )

    first, rand, again, other, d_opt = (
        made("first"), made("random"), made("random"), made("random", 5), made("d-optimal")
    )  # fmt: skip
    for plan in (first, rand, other, d_opt):
        assert len(planning.distinct(plan.plan.q_rad)) == 12
        assert all((pool == q).all(axis=1).any() for q in plan.plan.q_rad)
    # "first": the first 12 candidates to pass, in candidate order before ordering for time.
    rows = [int(np.flatnonzero((pool == q).all(axis=1))[0]) for q in first.plan.q_rad]
    assert max(rows) < min(
        int(np.flatnonzero((pool == q).all(axis=1))[0])
        for q in rand.plan.q_rad
        if not (first.plan.q_rad == q).all(axis=1).any()
    )
    # "random" repeats with its seed and changes with another.
    np.testing.assert_array_equal(rand.plan.path_rad, again.plan.path_rad)
    assert {tuple(q) for q in rand.plan.q_rad} != {tuple(q) for q in other.plan.q_rad}
    # D-optimal observes the parameters best.
    assert planning.log_det(d_opt.blocks) > max(planning.log_det(p.blocks) for p in (first, rand))
    with pytest.raises(
        planning.PlanError, match="unknown selection 'best'; use one of d-optimal, "
    ):
        made("best")


def _held_out_error(world, q_fit, q_val, rng, sigma_mm=0.01):
    """Identify (least squares) from simulated points at q_fit; mean error (mm) at q_val."""
    points = np.array([world.tool_pose(q)[:3, 3] for q in q_fit])
    table = session.to_table(q_fit, points + rng.normal(0.0, sigma_mm, points.shape))
    meta = session.SessionMeta("tracker", world.model.mdh, world.model.name, SIM_TOOL, False)
    result = pipeline.identify(
        session.Session(table, meta), pipeline.Options(method="lm", validation_fraction=0.0)
    )
    truth = np.array([world.tool_pose(q)[:3, 3] for q in q_val])
    pos, _ = measurement.errors(result.space, result.x, measurement.Observations(q_val, truth))
    return float(np.linalg.norm(pos, axis=1).mean())


def test_d_optimal_plan_beats_a_random_plan_of_the_same_size():
    n, better_criterion, errors_d, errors_r = 12, [], [], []
    where = cell.Cell(tracker_at_mm=tuple(SIM_TRACKER_AT_MM))
    box = planning.joint_box(UR10E.joint_limits_rad, np.radians(5))
    for seed in range(4):
        world = SimWorld.make("ur10e", seed)
        q_d, q_r = (
            planning.make_checked(UR10E, n, where, SIM_TOOL_MM, seed=seed, selection=s).plan.q_rad
            for s in ("d-optimal", "random")
        )
        q_val = planning.sample(box, 100, "random", seed + 100)
        crit = [
            planning.log_det(planning.observability(UR10E.mdh, q, SIM_TOOL).blocks)
            for q in (q_d, q_r)
        ]
        better_criterion.append(crit[0] > crit[1])
        rng = np.random.default_rng(seed)
        errors_d.append(_held_out_error(world, q_d, q_val, rng))
        errors_r.append(_held_out_error(world, q_r, q_val, rng))
    assert all(better_criterion)
    assert np.mean(errors_d) < 0.8 * np.mean(errors_r), (errors_d, errors_r)
