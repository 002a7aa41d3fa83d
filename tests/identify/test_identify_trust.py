"""Issue 9: the full tool frame, identifiability, uncertainty, robust and minimax fits."""

import json

import identify_kit as arms
import numpy as np
import pyarrow as pa
import pytest
from cli_process_kit import run_cli

from calibrator import session
from calibrator.errors import IdentifiabilityError
from calibrator.identify import pipeline
from calibrator.identify.problem import Problem
from calibrator.model import frames, rotations
from calibrator.simulate import simulate

DEG = np.pi / 180


def worst_validation(result):
    after = result.stats["validation"]["after"]
    orient = max(after["orientation_deg"][a]["max"] for a in "xyz")
    return after["position_mm"]["max"], orient


# --- the full tool frame -------------------------------------------------------------


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_probe_turned_half_a_degree_about_each_flange_axis_identifies_to_the_floor(axis):
    robot, true = arms.truth_arm("er10l-c10", seed=1)
    q = arms.joints(robot, 30, seed=2)
    turn = np.zeros(3)
    turn[axis] = 0.5 * DEG
    tool = frames.transform(rotations.rotvec_to_matrix(turn), [10.0, -5.0, 120.0])
    data = arms.loaded(robot, q, arms.measure(true, q, tool))  # identity guess, tool free
    result = pipeline.identify(data, pipeline.Options(method="lm"))
    assert {"tool_rx", "tool_ry", "tool_rz"} <= set(result.space.free)
    position, orientation = worst_validation(result)
    assert position < 1e-6 and orientation < 1e-6
    # Joints 1-5 are the truth; joint 6's constant part lives in the tool frame.
    np.testing.assert_allclose(result.mdh[:5], true[:5], atol=1e-8)
    np.testing.assert_array_equal(result.mdh[5], robot.mdh[5])


def test_probe_mounted_at_rz90_rx90_with_an_identity_guess():
    robot, true = arms.truth_arm("er10l-c10", seed=4)
    q = arms.joints(robot, 30, seed=5)
    mount = rotations.rotations_xyz([0, 0, np.pi / 2]) @ rotations.rotations_xyz([np.pi / 2, 0, 0])
    tool = frames.transform(mount, [0.0, 30.0, 90.0])
    data = arms.loaded(robot, q, arms.measure(true, q, tool), noise_mm=0.0)
    result = pipeline.identify(data, pipeline.Options())  # default: hybrid, lsq
    position, orientation = worst_validation(result)
    assert position < 1e-6 and orientation < 1e-6
    deltas = np.abs(result.mdh - robot.mdh)
    assert deltas[:, [0, 3]].max() < 1.0  # mm
    assert deltas[:, [1, 2, 4]].max() < 0.02  # rad: no +90 deg "deltas"
    # The mount is found: the identified tool rotation is within a degree of it
    # (joint 6's small errors are part of it).
    turn = rotations.matrix_to_rotvec(mount.T @ result.flange2tool[:3, :3])
    assert np.linalg.norm(turn) < 1 * DEG


# --- identifiability and warnings ----------------------------------------------------


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_position_only_free_tool_a5_is_within_its_error_or_dropped(seed):
    table, meta, truth = simulate(orientation=False, tool_offset_mm=5.0, noise_mm=0.02, seed=3)
    result = pipeline.identify(
        session.Session(table, meta), pipeline.Options(seed=seed, generations=300)
    )
    if "a5" in result.space.free:
        se = result.uncertainty["standard_errors"]["a5"]
        assert abs(result.mdh[4, 0] - truth.mdh[4, 0]) <= 3 * se
    else:
        reason = {d["name"]: d["reason"] for d in result.dropped}["a5"]
        assert "standard error" in reason and "mm" in reason
        assert result.mdh[4, 0] == meta.nominal_mdh[4, 0]


def test_a_tool_on_the_flange_axis_fixes_theta6_with_a_reason():
    table, meta, _ = simulate(orientation=False, noise_mm=0.02, seed=3, errors="random")
    assert meta.tool_known and np.allclose(meta.flange2tool[:2, 3], 0.0)
    result = pipeline.identify(session.Session(table, meta), pipeline.Options(method="lm"))
    assert "theta6" not in result.space.free
    reason = {d["name"]: d["reason"] for d in result.dropped}["theta6"]
    # Exactly on the axis, theta6 moves no measured point: pruned as having no
    # effect (before the free set is judged on these poses, which would drop it too).
    assert reason in ("has no effect on any measured pose",) or "not determined" in reason


def test_ten_position_only_poses_for_27_parameters_warn():
    table, meta, _ = simulate(
        orientation=False, poses=10, noise_mm=0.02, seed=3, frame="tracker", tool_offset_mm=3.0
    )
    result = pipeline.identify(
        session.Session(table, meta), pipeline.Options(method="lm", validation_fraction=0)
    )
    assert any("measured values for" in w and "per parameter" in w for w in result.warnings)


def test_noise_above_the_assumed_level_is_warned_about():
    table, meta, _ = simulate(poses=30, noise_mm=0.5, seed=3)
    result = pipeline.identify(session.Session(table, meta), pipeline.Options(method="lm"))
    assert any("--noise-mm" in w for w in result.warnings)
    quiet = pipeline.identify(
        session.Session(table, meta), pipeline.Options(method="lm", noise_mm=0.5)
    )
    assert not any("--noise-mm" in w for w in quiet.warnings)


def test_identical_poses_are_refused_and_repeats_are_warned_about():
    table, meta, _ = simulate(orientation=False, poses=30, seed=3)
    same = pa.concat_tables([table.slice(0, 1)] * 30)
    same = same.set_column(0, "pose", pa.array(np.arange(30)))
    with pytest.raises(IdentifiabilityError, match="distinct"):
        pipeline.identify(session.Session(same, meta), pipeline.Options(method="lm"))
    repeated = pa.concat_tables([table, table.slice(0, 5)])
    repeated = repeated.set_column(0, "pose", pa.array(np.arange(35)))
    result = pipeline.identify(
        session.Session(repeated, meta), pipeline.Options(method="lm", validation_fraction=0)
    )
    assert any("5 pose(s) repeat" in w for w in result.warnings)


def test_a_session_above_the_pose_limit_is_one_line_and_exit_2(tmp_path):
    # Issue 8, item 9: a 1,000,000-row session ran past 600 s and 8 GB.
    robot, true = arms.truth_arm("ur5e", seed=1)
    q = arms.joints(robot, pipeline.MAX_POSES + 1, seed=1)
    data = arms.loaded(robot, q, arms.measure(true, q, np.eye(4)), orientation=False)
    path = tmp_path / "big.parquet"
    session.write(path, data.table, data.meta)
    run = run_cli("identify", path, "-o", tmp_path / "c.json", timeout=60)
    assert run.returncode == 2
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and f"at most {pipeline.MAX_POSES}" in lines[0], run.stderr
    assert not (tmp_path / "c.json").exists()


# --- uncertainty -----------------------------------------------------------------------


def test_standard_errors_match_the_spread_over_50_noise_seeds():
    robot, true = arms.truth_arm("er10l-c10", seed=7)
    q = arms.joints(robot, 24, seed=8)
    tool = frames.transform(translation=[0.0, 0.0, 100.0])
    pose = arms.measure(true, q, tool)
    xs, ses = [], []
    for seed in range(50):
        data = arms.loaded(
            robot,
            q,
            pose,
            noise_mm=0.03,
            noise_rad=2e-4,
            seed=seed,
            tool_guess=tool,
            tool_known=True,
        )
        result = pipeline.identify(data, pipeline.Options(method="lm", validation_fraction=0))
        xs.append(result.x)
        ses.append([result.uncertainty["standard_errors"][n] for n in result.space.free])
    empirical = np.std(xs, axis=0, ddof=1)
    predicted = np.sqrt(np.mean(np.square(ses), axis=0))
    assert len(empirical) == 24
    # theta2 sits about 3 SD of this 50-seed estimate low (0.72 with the old equal
    # split of the degrees of freedom, 0.67 with the hat-matrix block sigmas, which
    # bring the mean ratio of the 24 to 1.00 from 1.04): 0.35.
    np.testing.assert_allclose(empirical / predicted, 1.0, atol=0.35)
    assert np.mean(empirical / predicted) == pytest.approx(1.0, abs=0.05)


def test_uncertainty_is_written_and_predicts_the_held_out_error(tmp_path):
    table, meta, _ = simulate(poses=40, noise_mm=0.02, seed=5)
    result = pipeline.identify(session.Session(table, meta), pipeline.Options(method="lm"))
    unc = result.uncertainty
    assert set(unc["standard_errors"]) == set(result.space.free)
    corr = np.array(unc["correlation"]["matrix"])
    np.testing.assert_allclose(np.diag(corr), 1.0, atol=1e-9)
    for pair in unc["strong_correlations"]:
        i, j = (unc["correlation"]["names"].index(pair[n]) for n in ("a", "b"))
        assert abs(corr[i, j]) > 0.9
    predicted = unc["predicted_validation_mm"]["error_mean"]
    actual = result.stats["validation"]["after"]["position_mm"]["mean"]
    assert 0.5 < actual / predicted < 2.0


# --- robust and minimax fits ---------------------------------------------------------


@pytest.mark.parametrize("loss", ["huber", "trimmed"])
def test_a_2mm_outlier_does_not_drag_a_robust_fit_and_is_named(loss):
    robot, true = arms.truth_arm("er10l-c10", seed=1)
    q = arms.joints(robot, 30, seed=2)
    tool = frames.transform(translation=[0.0, 0.0, 100.0])
    pose = arms.measure(true, q, tool)
    kw = dict(noise_mm=0.02, noise_rad=1e-4, tool_guess=tool, tool_known=True)
    clean = pipeline.identify(arms.loaded(robot, q, pose, **kw), pipeline.Options(method="lm"))
    fit_idx, _ = pipeline.split(30, 0.2, 0)
    bad = pose.copy()
    bad[fit_idx[5], :3, 3] += 2.0 * np.array([0.6, 0.8, 0.0])  # reseated 2 mm off
    data = arms.loaded(robot, q, bad, **kw)
    result = pipeline.identify(data, pipeline.Options(method="lm", loss=loss))
    plain = pipeline.identify(data, pipeline.Options(method="lm"))

    def held(r):
        return r.stats["validation"]["after"]["position_mm"]["mean"]

    assert held(result) <= 1.2 * held(clean)
    assert held(plain) > 1.5 * held(clean)  # the outlier does drag plain least squares
    assert result.outliers == [int(fit_idx[5])]


def compliant_session(noise_mm, compliance_rad):
    robot, true = arms.truth_arm("er10l-c10", seed=1)
    q = arms.joints(robot, 60, seed=2)
    tool = frames.transform(translation=[0.0, 0.0, 100.0])
    pose = arms.measure(true, q, tool, compliance_rad=compliance_rad)
    return arms.loaded(
        robot, q, pose, noise_mm=noise_mm, orientation=False, tool_guess=tool, tool_known=True
    )


def test_minimax_lowers_the_worst_fitted_error_under_unmodelled_compliance():
    data = compliant_session(0.01, 2e-4)
    options = dict(validation_fraction=0.3, generations=400)
    lsq = pipeline.identify(data, pipeline.Options(**options))
    mmx = pipeline.identify(data, pipeline.Options(loss="minimax", **options))
    lsq_max = lsq.stats["fit"]["after"]["position_mm"]["max"]
    mmx_max = mmx.stats["fit"]["after"]["position_mm"]["max"]
    assert mmx_max < 0.9 * lsq_max
    assert mmx.details["minimax"]["worst_mm"] == pytest.approx(mmx_max, rel=1e-6)
    assert len(mmx.details["convergence"]) <= pipeline.CONVERGENCE_POINTS


def test_under_gaussian_noise_least_squares_wins_the_held_out_mean():
    data = compliant_session(0.02, 0.0)
    options = dict(method="lm", validation_fraction=0.3)
    lsq = pipeline.identify(data, pipeline.Options(**options))
    mmx = pipeline.identify(data, pipeline.Options(loss="minimax", **options))
    mean = [r.stats["validation"]["after"]["position_mm"]["mean"] for r in (lsq, mmx)]
    assert mean[0] <= mean[1]


# --- the swarm -----------------------------------------------------------------------


def test_swarm_reports_each_generation_and_sees_a_bounded_subset():
    table, meta, _ = simulate(poses=100, noise_mm=0.02, seed=5)
    seen = []
    result = pipeline.identify(
        session.Session(table, meta),
        pipeline.Options(generations=50),
        on_generation=lambda g, f: seen.append((g, f)),
    )
    assert [g for g, _ in seen] == list(range(1, 51))
    assert all(b <= a for (_, a), (_, b) in zip(seen, seen[1:], strict=False))
    assert result.details["pso"]["poses"] == pipeline.Options().swarm_poses < len(result.fit_index)
    curve = result.details["convergence"]
    assert curve[0][0] == 0 and curve[-1] == [50, seen[-1][1]]


# --- defaults and the command line ---------------------------------------------------


def test_the_default_loss_is_least_squares_and_the_cli_writes_the_new_keys(tmp_path):
    assert pipeline.Options().loss == "lsq"
    table, meta, _ = simulate(poses=30, noise_mm=0.02, seed=6)
    path = tmp_path / "s.parquet"
    session.write(path, table, meta)
    out = tmp_path / "c.json"
    run = run_cli("identify", path, "-o", out, "--method", "lm")
    assert run.returncode == 0, run.stderr
    doc = json.loads(out.read_text())
    assert doc["loss"] == "lsq"
    assert set(doc["uncertainty"]["standard_errors"]) == set(doc["free_parameters"])
    assert doc["outliers"] == [] and isinstance(doc["warnings"], list)
    assert "standard errors" in run.stdout and "predicted held-out" in run.stdout


@pytest.mark.parametrize("frame", ["base", "tracker"])
def test_swarm_objective_with_the_full_tool_frame_matches_the_residuals(frame):
    from calibrator.model import measurement, parameters

    robot, true = arms.truth_arm("ur10e", seed=3)
    q = arms.joints(robot, 12, seed=4)
    mount = rotations.rotations_xyz([np.pi / 2, 0.3, np.pi / 2])
    tool = frames.transform(mount, [5.0, 1.0, 90.0])
    base = np.eye(4)
    if frame == "tracker":
        base = frames.transform(
            rotations.rotvec_to_matrix([0.4, -1.0, 2.0]), [3000.0, 200.0, -50.0]
        )
    data = arms.loaded(robot, q, arms.measure(true, q, tool, base), noise_mm=0.05, noise_rad=1e-4)
    obs = data.observations
    names, _ = parameters.structural_candidates(robot.mdh, frame, False, True)
    assert {"tool_rx", "tool_ry", "tool_rz"} <= set(names)
    space = parameters.ParameterSpace(robot.mdh, base, tool, names)
    swarm = np.random.default_rng(0).normal(0, 0.002, (5, space.size))
    k = 1e4
    per_pose = [
        (measurement.residuals(space, x, obs, k) ** 2).reshape(2, len(obs), 3).sum(axis=(0, 2))
        for x in swarm
    ]
    # The swarm's chordal orientation term equals theta^2 to fourth order.
    lsq = Problem.of(space, obs, k).swarm_objective()(swarm)
    np.testing.assert_allclose(lsq, [p.sum() for p in per_pose], rtol=1e-5)
    worst = Problem.of(space, obs, k).swarm_objective("minimax")(swarm)
    np.testing.assert_allclose(worst, [p.max() for p in per_pose], rtol=1e-5)
