"""Pose plans: cell constraints, whole-plan validation, and D-optimal selection paying off."""

import numpy as np
import pytest
from cli_process_kit import run_cli

from calibrator import plan as plans
from calibrator import robots, session
from calibrator.identify import pipeline
from calibrator.model import frames, kinematics, measurement
from calibrator.simulate import DEFAULT_TOOL_POINT, SIM_TRACKER_AT_MM, SimWorld

TOOL = frames.transform(translation=DEFAULT_TOOL_POINT)
UR10E = robots.get("ur10e")


def test_plan_respects_limits_margin_acceptance_angle_and_floor():
    cell = plans.CellConstraints(
        margin_rad=np.radians(10),
        tracker_at_mm=SIM_TRACKER_AT_MM,
        acceptance_rad=np.radians(25),
        floor_mm=200.0,
        flange2tool=TOOL,
    )
    q = plans.make(UR10E.mdh, UR10E.joint_limits_rad, 25, cell, seed=4)
    assert q.shape == (25, 6)
    box = plans.joint_box(UR10E.joint_limits_rad, np.radians(10))
    assert np.all(q >= box[:, 0]) and np.all(q <= box[:, 1])
    assert np.all(np.abs(q) <= np.pi - np.radians(10) + 1e-12)
    base2flange, link = kinematics.chain(UR10E.mdh, q, all_frames=True)
    tool = base2flange @ TOOL
    to_tracker = SIM_TRACKER_AT_MM - tool[:, :3, 3]
    cos = np.einsum("nj,nj->n", tool[:, :3, 2], to_tracker) / np.linalg.norm(to_tracker, axis=1)
    assert np.degrees(np.arccos(cos)).max() <= 25.0
    assert tool[:, 2, 3].min() >= 200.0 and link[:, 4:, 2, 3].min() >= 200.0
    # The filters do bite: unconstrained candidates break each constraint.
    pool = plans.sample(box, 500, "halton", 4)
    assert not plans.feasible(UR10E.mdh, pool, cell).all()


def _held_out_error(cell, q_fit, q_val, rng, sigma_mm=0.01):
    """Identify (least squares) from simulated points at q_fit; mean error (mm) at q_val."""
    points = np.array([cell.tool_pose(q)[:3, 3] for q in q_fit])
    table = session.to_table(q_fit, points + rng.normal(0.0, sigma_mm, points.shape))
    meta = session.SessionMeta("tracker", cell.model.mdh, cell.model.name, TOOL, False)
    result = pipeline.identify(
        session.Session(table, meta), pipeline.Options(method="lm", validation_fraction=0.0)
    )
    truth = np.array([cell.tool_pose(q)[:3, 3] for q in q_val])
    pos, _ = measurement.errors(result.space, result.x, measurement.Observations(q_val, truth))
    return float(np.linalg.norm(pos, axis=1).mean())


def test_d_optimal_plan_beats_a_random_plan_of_the_same_size():
    n, better_criterion, errors_d, errors_r = 12, [], [], []
    for seed in range(4):
        cell = SimWorld.make("ur10e", seed)
        constraints = plans.CellConstraints(tracker_at_mm=SIM_TRACKER_AT_MM, flange2tool=TOOL)
        args = (UR10E.mdh, UR10E.joint_limits_rad)
        q_d = plans.make(*args, n, constraints, seed=seed)
        q_r = plans.make(*args, n, constraints, seed=seed, selection="random")
        q_val = plans.make(*args, 100, constraints, seed=seed + 100, selection="random")
        crit = [plans.log_det(plans.observability(UR10E.mdh, q, TOOL).blocks) for q in (q_d, q_r)]
        better_criterion.append(crit[0] > crit[1])
        rng = np.random.default_rng(seed)
        errors_d.append(_held_out_error(cell, q_d, q_val, rng))
        errors_r.append(_held_out_error(cell, q_r, q_val, rng))
    assert all(better_criterion)
    assert np.mean(errors_d) < 0.8 * np.mean(errors_r), (errors_d, errors_r)


def test_validate_refuses_whole_plan_out_of_limits_or_too_short():
    q = np.zeros((12, 6))
    q[7, 2] = 3.5  # elbow beyond pi
    with pytest.raises(plans.PlanError, match="plan row 7 joint 3"):
        plans.validate(q, UR10E.joint_limits_rad)
    need = plans.min_poses(UR10E.mdh)
    assert 8 <= need <= 12
    with pytest.raises(plans.PlanError, match=f"need at least {need}"):
        plans.validate(np.zeros((need - 1, 6)), UR10E.joint_limits_rad, need=need)


def test_plan_cli_writes_a_plan_measure_then_uses(tmp_path):
    made = run_cli(
        "plan", "-o", "plan.csv", "--poses", "10", "--tracker-at", "2500,400,300", cwd=tmp_path
    )
    assert made.returncode == 0, made.stderr
    assert "wrote plan.csv: 10 poses" in made.stdout and "d-optimal selection" in made.stdout
    q = plans.read_plan(tmp_path / "plan.csv").q_rad
    assert q.shape == (10, 6)
    done = run_cli("measure", "--plan", "plan.csv", "-o", "s.parquet", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    loaded = session.load(tmp_path / "s.parquet")
    np.testing.assert_allclose(loaded.array(session.JOINT_COLUMNS), q, atol=1e-12)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (("plan", "--tracker-at", "1,2"), "--tracker-at: needs X,Y,Z"),
        (("plan", "-o", "nodir/p.csv"), "folder nodir does not exist"),
        (("plan", "--from", "missing.csv"), "cannot read plan missing.csv"),
        (("measure", "--plan", "bad.csv"), "plan row 1 joint 3"),
        (("measure", "--plan", "short.csv"), "the free parameters need at least"),
        (("measure", "--robot", "ftp://x"), "--robot: unknown robot"),
        (("measure", "--tracker", "gopher://x"), "--tracker: unknown tracker"),
        (("measure", "--speed", "3"), "--speed 3.0 rad/s outside"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(tmp_path, args, message):
    # Distinct poses (a repeated pose is refused by the reader before anything else).
    steps = 0.01 * np.arange(10)[:, None]
    bad = np.array([[0.0] * 6, [0, 0, 4.0, 0, 0, 0]] * 5) + steps * [1, 1, 0, 1, 1, 1]
    plans.write_csv(tmp_path / "bad.csv", bad)
    plans.write_csv(tmp_path / "short.csv", 0.01 * np.arange(18.0).reshape(3, 6))
    done = run_cli(*args, cwd=tmp_path)
    assert done.returncode == 2, done.stderr
    assert message in done.stderr and done.stderr.count("\n") == 1, done.stderr
    assert not list(tmp_path.glob("*.journal")) and not list(tmp_path.glob(".*tmp"))


def test_the_plan_size_for_three_values_per_parameter_after_the_hold_out():
    """30 poses of a UR10e in the tracker frame leave 2.9 values per parameter: 31 leave 3."""
    from calibrator.identify import freeset, identifiability

    mdh = robots.get("ur10e").mdh
    n = freeset.poses_for(mdh, "tracker", False, 0.2)
    free = len(freeset.decide(mdh, "tracker", False, False).names)
    assert free == 25 and n == 31
    for poses, warned in ((n, False), (n - 1, True)):
        fit = poses - round(0.2 * poses)
        assert (3 * fit / free < identifiability.MIN_VALUES_PER_PARAMETER) is warned, poses
    assert freeset.poses_for(mdh, "tracker", False, 0.2, orientation=True) < n
    assert plans.min_poses(mdh) == -(-free // 3)  # both from the one free-set decision
