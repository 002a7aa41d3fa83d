"""Compensation on a simulated arm with hidden errors, through identify."""

import numpy as np
import pandas as pd
import pytest
from cli_process_kit import run_cli  # the CLI as a user runs it: a real process

from calibrator import compensate, robots, session, simulate
from calibrator.calibration import Calibration
from calibrator.identify import pipeline
from calibrator.model import inverse, kinematics, rotations


@pytest.fixture(scope="module")
def identified(tmp_path_factory):
    table, meta, truth = simulate.simulate(
        model="ur10e",
        poses=60,
        seed=5,
        frame="base",
        errors="random",
        noise_mm=0.01,
        orientation_noise_rad=1e-5,
    )
    path = tmp_path_factory.mktemp("s") / "s.parquet"
    session.write(path, table, meta)
    loaded = session.load(path)
    result = pipeline.identify(loaded, pipeline.Options(method="lm", validation_fraction=0.25))
    cal = Calibration.from_result(result, path, "ur10e", "base")
    return cal, truth, result.stats["validation"]["after"]["position_mm"]


def targets(n, seed=2):
    # A work cell in front of the robot: away from the shoulder and wrist singularities.
    rng = np.random.default_rng(seed)
    q = np.column_stack(
        [
            rng.uniform(-1.0, 1.0, n),
            rng.uniform(-2.2, -1.0, n),
            rng.uniform(0.6, 2.0, n),
            rng.uniform(-2.5, -0.5, n),
            rng.uniform(0.5, 2.5, n),
            rng.uniform(-3.0, 3.0, n),
        ]
    )
    return q


def test_corrected_targets_land_within_held_out_error(identified):
    cal, truth, held_out = identified
    q_nom = targets(200)
    out = compensate.compensate(cal, q_nominal=q_nom, limits=robots.get("ur10e").joint_limits_rad)
    ok = out.solution.ok
    # The simulated errors are large (0.5 deg): a few poses near the edge of
    # the work space have no solution on the real arm; they are reported.
    assert ok.mean() > 0.9
    assert np.all(out.solution.error_mm[~ok] > inverse.TOL_MM)
    desired = out.desired[ok, :3, 3]
    true_tool = truth.flange2tool
    # The controller keeps its nominal model: sent the corrected target, its
    # nominal IK returns out.q, and the real arm moves there.
    nominal_ik = inverse.solve(cal.nominal_mdh, out.corrected[ok], q_nom[ok], cal.flange2tool)
    assert nominal_ik.converged.all()
    np.testing.assert_allclose(nominal_ik.q, out.q[ok], atol=1e-8)
    landed = (kinematics.chain(truth.mdh, nominal_ik.q) @ true_tool)[:, :3, 3]
    uncorrected = (kinematics.chain(truth.mdh, q_nom[ok]) @ true_tool)[:, :3, 3]
    err = np.linalg.norm(landed - desired, axis=1)
    before = np.linalg.norm(uncorrected - desired, axis=1)
    assert before.mean() > 2.0  # several mm without compensation
    assert err.max() <= held_out["max"] + 0.01 and err.mean() <= held_out["mean"] + 0.005


def test_joint_limits_are_reported_not_clipped(identified):
    cal, _, _ = identified
    q_nom = targets(5)
    free = compensate.compensate(cal, q_nominal=q_nom)
    limits = np.tile([-2 * np.pi, 2 * np.pi], (6, 1))
    limits[2, 1] = free.q[0, 2] - 1e-6  # target 1 needs the elbow just past its limit
    out = compensate.compensate(cal, q_nominal=q_nom, limits=limits)
    assert free.solution.ok[0] and not out.solution.ok[0]
    past = free.q[:, 2] > limits[2, 1]
    assert out.solution.ok.tolist() == (free.solution.ok & ~past).tolist()
    assert out.solution.converged[0] and not out.solution.within_limits[0]
    assert out.q[0, 2] == free.q[0, 2] > limits[2, 1]


def test_pose_targets_and_csv_cli(identified, tmp_path):
    cal, _, _ = identified
    cal.save(tmp_path / "cal.json")
    q_nom = targets(20, seed=3)
    pose = kinematics.tool_poses(cal.nominal_mdh, q_nom, cal.flange2tool)
    pose[0, 0, 3] += 5000.0  # out of reach
    data = {f"q{i + 1}_rad": q_nom[:, i] + 0.01 for i in range(6)}  # a rough start
    data.update(zip(("x_mm", "y_mm", "z_mm"), pose[:, :3, 3].T, strict=True))
    data.update(
        zip(
            ("rx_rad", "ry_rad", "rz_rad"),
            rotations.matrix_to_rotvec(pose[:, :3, :3]).T,
            strict=True,
        )
    )
    pd.DataFrame(data).to_csv(tmp_path / "t.csv", index=False)
    done = run_cli("compensate", "cal.json", "t.csv", "-o", "out.csv", cwd=tmp_path)
    out = pd.read_csv(tmp_path / "out.csv")
    expected = compensate.compensate(cal, pose, q_nom + 0.01)
    jump = np.degrees(np.max(np.abs(expected.q - expected.q_nominal), axis=1))
    # Near the shoulder singularity a joint swings: refused, not "ok" (issue 32).
    ok = expected.solution.ok & (jump <= compensate.MAX_JOINT_CHANGE_DEG)
    assert not ok[0] and ok[1:].mean() > 0.6 and (jump[1:] > 5).any()
    assert (out.status == "ok").tolist() == ok.tolist()
    np.testing.assert_allclose(
        out.loc[ok, [f"q{i}_rad" for i in range(1, 7)]].to_numpy(), expected.q[ok], atol=1e-8
    )
    assert done.returncode == 1
    assert "target 0: not reached" in done.stderr  # numbered from 0, as plans are
    assert out.loc[0, ["q1_rad", "x_mm"]].isna().all()  # reported, not clipped


def test_bad_targets_file(identified, tmp_path):
    cal, _, _ = identified
    cal.save(tmp_path / "cal.json")
    (tmp_path / "t.csv").write_text("q1_rad,q2_rad\n0,0\n")
    done = run_cli("compensate", "cal.json", "t.csv", "-o", "o.csv", cwd=tmp_path)
    assert done.returncode == 2 and "missing column(s) q3_rad" in done.stderr
    assert not (tmp_path / "o.csv").exists()
