"""Target compensation in process: the IK reaches the targets through the
identified model, targets are independent of each other, iterations and
remaining errors are what they say, and the targets CSV and the command refuse
bad input in one line."""

from dataclasses import replace

import numpy as np
import pandas as pd
import pytest
from cli_kit import cli, one_line_error
from export_kit import rot
from scipy.spatial.transform import Rotation

from calibrator import compensate, robots, simulate
from calibrator.calibration import Calibration
from calibrator.errors import CalibrationError
from calibrator.model import frames, inverse, kinematics, parameters, rotations

UR10E = robots.get("ur10e")


def calibrated(seed=5, model="ur10e", tool_xy=(0.0, 0.0)):
    """A UR10e whose identified table has errors of a few mm and mrad; a tool
    100 mm along the flange axis (shifted by ``tool_xy``)."""
    rng = np.random.default_rng(seed)
    nominal = UR10E.mdh
    mdh = nominal + simulate.random_errors(nominal, rng, mm=1.0, rad=0.002)
    tool = frames.transform(None, [tool_xy[0], tool_xy[1], 100.0])
    free = parameters.structural_candidates(nominal, "base", True)[0]
    space = parameters.ParameterSpace(nominal, free=tuple(free))
    return Calibration(
        nominal_mdh=nominal,
        mdh=mdh,
        flange2tool=tool,
        model=model,
        free=free,
        deltas=dict(zip(space.free, space.pack(mdh), strict=True)),
    )


def tool_on_axis_6(cal):
    """The same arm with the flange on axis 6 (a6 = alpha6 = 0): the tool point
    (on the flange's z axis) then stays put when joint 6 turns."""
    mdh = cal.mdh.copy()
    mdh[5, [kinematics.A, kinematics.ALPHA]] = 0.0
    return replace(cal, mdh=mdh)


def work_cell(n, seed=2):
    """Joint targets in front of the robot, away from its singularities (rad)."""
    rng = np.random.default_rng(seed)
    lo = np.array([-1.0, -2.2, 0.6, -2.5, 0.5, -3.0])
    hi = np.array([1.0, -1.0, 2.0, -0.5, 2.5, 3.0])
    return rng.uniform(lo, hi, (n, 6))


def angle_between(a, b):
    """Rotation angle (rad) from b to a, (N, 3, 3), by scipy."""
    return Rotation.from_matrix(np.swapaxes(b, -1, -2) @ a).magnitude()


def test_joints_found_reach_the_targets_through_the_identified_model():
    cal = calibrated()
    q_nom = work_cell(30)
    out = compensate.compensate(cal, q_nominal=q_nom, limits=UR10E.joint_limits_rad)
    # Target 2 lies where the real arm cannot quite reach: reported, not faked.
    ok = out.solution.ok
    assert ok.tolist() == [i != 1 for i in range(30)]
    assert out.solution.error_mm[1] > 1.0 and not out.solution.converged[1]
    # The desired poses are where the nominal model puts the tool at q_nom ...
    nominal_pose = kinematics.chain(cal.nominal_mdh, q_nom) @ cal.flange2tool
    np.testing.assert_allclose(out.desired, nominal_pose, atol=1e-9)
    # ... the real (identified) arm gets there at out.q ...
    reached = (kinematics.chain(cal.mdh, out.q) @ cal.flange2tool)[ok]
    assert np.abs(reached[:, :3, 3] - nominal_pose[ok, :3, 3]).max() < inverse.TOL_MM
    assert angle_between(reached[:, :3, :3], nominal_pose[ok, :3, :3]).max() < 1e-9
    # ... and the corrected target is where the nominal model puts it at out.q.
    sent = kinematics.chain(cal.nominal_mdh, out.q) @ cal.flange2tool
    np.testing.assert_allclose(out.corrected, sent, atol=1e-9)
    # The errors are large: without compensation the arm misses by mm.
    miss = kinematics.chain(cal.mdh, q_nom) @ cal.flange2tool
    assert np.linalg.norm(miss[:, :3, 3] - nominal_pose[:, :3, 3], axis=1).min() > 0.5


def test_desired_poses_start_from_the_nominal_solution():
    cal = calibrated(seed=6)
    q_true = work_cell(12, seed=4)
    desired = kinematics.chain(cal.nominal_mdh, q_true) @ cal.flange2tool
    # Integer-valued poses from a file are poses too.
    desired[0, :3, 3] = np.round(desired[0, :3, 3])
    out = compensate.compensate(cal, desired.tolist(), q_true + 0.02)
    assert out.solution.converged.all()
    reached = kinematics.chain(cal.mdh, out.q) @ cal.flange2tool
    np.testing.assert_allclose(reached[:, :3, 3], desired[:, :3, 3], rtol=0, atol=1e-6)
    np.testing.assert_allclose(out.desired, desired, atol=0)


def test_without_a_tool_the_flange_reaches_the_target():
    mdh = calibrated().mdh
    q_true = work_cell(8, seed=7)
    targets = kinematics.chain(mdh, q_true)
    sol = inverse.solve(mdh, targets, q_true + 0.05)
    assert sol.converged.all() and sol.within_limits.all()
    np.testing.assert_allclose(kinematics.chain(mdh, sol.q)[:, :3, 3], targets[:, :3, 3], atol=1e-6)


def test_a_turn_about_the_tool_axis_alone_is_still_solved():
    """Tool point on axis 6: a start off only in q6 has no position error."""
    cal = tool_on_axis_6(calibrated(seed=8))
    q_true = work_cell(6, seed=9)
    targets = kinematics.chain(cal.mdh, q_true) @ cal.flange2tool
    start = q_true.copy()
    start[:, 5] += 0.3
    sol = inverse.solve(cal.mdh, targets, start, cal.flange2tool)
    assert sol.converged.all() and (sol.iterations >= 1).all()
    reached = kinematics.chain(cal.mdh, sol.q) @ cal.flange2tool
    assert angle_between(reached[:, :3, :3], targets[:, :3, :3]).max() < 2e-8
    np.testing.assert_allclose(sol.q, q_true, atol=1e-8)
    assert (sol.error_rad < inverse.TOL_RAD).all()


def test_without_iterations_the_errors_are_those_of_the_start(monkeypatch):
    """Tool point on axis 6, start off in q6 only: no position error, all rotation."""
    cal = tool_on_axis_6(calibrated(seed=26))
    q_true = work_cell(3, seed=27)
    targets = kinematics.chain(cal.mdh, q_true) @ cal.flange2tool
    start = q_true.copy()
    start[:, 5] += [0.1, -0.2, 0.3]
    monkeypatch.setattr(inverse, "MAX_ITER", 0)
    sol = inverse.solve(cal.mdh, targets, start, cal.flange2tool)
    assert not sol.converged.any() and sol.iterations.tolist() == [0, 0, 0]
    np.testing.assert_array_equal(sol.q, start)
    assert sol.error_mm.max() < 1e-9
    np.testing.assert_allclose(sol.error_rad, [0.1, 0.2, 0.3], rtol=1e-9)


def test_newton_steps_converge_in_a_few_iterations():
    """From 0.1 rad off, damped Newton steps on the true Jacobian need a handful."""
    cal = calibrated(seed=13)
    targets, start = mixed_targets(cal)
    sol = inverse.solve(cal.mdh, targets, start, cal.flange2tool)
    assert sol.converged.tolist() == [True, True, False, True, True]
    assert sol.iterations[sol.converged].max() <= 6


def test_a_target_already_reached_takes_no_iteration():
    cal = calibrated()
    q = work_cell(3)
    targets = kinematics.chain(cal.mdh, q) @ cal.flange2tool
    sol = inverse.solve(cal.mdh, targets, q, cal.flange2tool)
    assert sol.converged.all() and sol.iterations.tolist() == [0, 0, 0]
    assert sol.error_mm.max() < 1e-9 and sol.error_rad.max() < 1e-12


def mixed_targets(cal):
    q_true = work_cell(5, seed=11)
    targets = kinematics.chain(cal.mdh, q_true) @ cal.flange2tool
    targets[2, 0, 3] += 5000.0  # far out of reach
    start = q_true + np.random.default_rng(3).uniform(-0.1, 0.1, q_true.shape)
    return targets, start


def test_targets_are_solved_independently_of_each_other():
    cal = calibrated(seed=12)
    targets, start = mixed_targets(cal)
    batch = inverse.solve(cal.mdh, targets, start, cal.flange2tool)
    assert batch.converged.tolist() == [True, True, False, True, True]
    for i in range(len(targets)):
        alone = inverse.solve(cal.mdh, targets[i : i + 1], start[i : i + 1], cal.flange2tool)
        # Batched and single linear algebra differ in the last bit only.
        np.testing.assert_allclose(alone.q[0], batch.q[i], rtol=0, atol=1e-12)
        assert alone.iterations[0] == batch.iterations[i]
        assert alone.error_mm[0] == pytest.approx(batch.error_mm[i], rel=1e-9, abs=1e-12)
        assert alone.error_rad[0] == pytest.approx(batch.error_rad[i], rel=1e-6, abs=1e-14)


def test_iterations_are_the_steps_the_target_needed(monkeypatch):
    """A target reported after k iterations converges with a cap of k, not k - 1."""
    cal = calibrated(seed=13)
    targets, start = mixed_targets(cal)
    sol = inverse.solve(cal.mdh, targets, start, cal.flange2tool)
    assert np.issubdtype(sol.iterations.dtype, np.integer)
    for i in (0, 1, 3):
        k = int(sol.iterations[i])
        assert 1 <= k < inverse.MAX_ITER
        monkeypatch.setattr(inverse, "MAX_ITER", k)
        assert inverse.solve(
            cal.mdh, targets[i : i + 1], start[i : i + 1], cal.flange2tool
        ).converged[0]
        monkeypatch.setattr(inverse, "MAX_ITER", k - 1)
        assert not inverse.solve(
            cal.mdh, targets[i : i + 1], start[i : i + 1], cal.flange2tool
        ).converged[0]
        monkeypatch.undo()


def test_an_unreachable_target_reports_what_is_left():
    cal = calibrated(seed=14)
    targets, start = mixed_targets(cal)
    sol = inverse.solve(cal.mdh, targets, start, cal.flange2tool)
    assert not sol.converged[2] and sol.converged.sum() == 4
    reached = kinematics.chain(cal.mdh, sol.q) @ cal.flange2tool
    left_mm = np.linalg.norm(reached[:, :3, 3] - targets[:, :3, 3], axis=1)
    left_rad = angle_between(targets[:, :3, :3], reached[:, :3, :3])
    np.testing.assert_allclose(sol.error_mm, left_mm, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(sol.error_rad, left_rad, rtol=1e-6, atol=2e-8)
    # Out by 5 m along x, it stops at the edge of the reach: metres short.
    assert 3000.0 < sol.error_mm[2] < 5000.0 and sol.error_rad.shape == (5,)


def test_joint_limits_are_inclusive_at_both_ends():
    cal = calibrated(seed=15)
    q = work_cell(2, seed=16)
    free = compensate.compensate(cal, q_nominal=q)
    assert free.solution.converged.all()
    limits = np.tile([-2 * np.pi, 2 * np.pi], (6, 1))
    limits[1] = (
        [free.q[0, 1], free.q[1, 1]]
        if free.q[0, 1] < free.q[1, 1]
        else [free.q[1, 1], free.q[0, 1]]
    )
    out = compensate.compensate(cal, q_nominal=q, limits=limits)
    np.testing.assert_array_equal(out.q, free.q)
    assert out.solution.within_limits.tolist() == [True, True]
    assert out.solution.ok.tolist() == [True, True]
    limits[1] = [free.q[:, 1].min() + 1e-9, free.q[:, 1].max() - 1e-9]
    out = compensate.compensate(cal, q_nominal=q, limits=limits)
    assert out.solution.within_limits.tolist() == [False, False]
    assert out.solution.converged.tolist() == [True, True]


# --- the targets file and the command -------------------------------------


def targets_csv(path, q, pose=None):
    data = {f"q{i + 1}_rad": q[:, i] for i in range(6)}
    if pose is not None:
        data.update(zip(("x_mm", "y_mm", "z_mm"), pose[:, :3, 3].T, strict=True))
        rv = rotations.matrix_to_rotvec(pose[:, :3, :3])
        data.update(zip(("rx_rad", "ry_rad", "rz_rad"), rv.T, strict=True))
    pd.DataFrame(data).to_csv(path, index=False)
    return path


def test_read_targets_gives_joints_and_poses(tmp_path):
    q = work_cell(4)
    pose = kinematics.chain(UR10E.mdh, q)
    pose[:, :3, :3] = pose[:, :3, :3] @ rot("z", 0.2)
    got_q, got_pose = compensate.read_targets(targets_csv(tmp_path / "t.csv", q, pose))
    np.testing.assert_allclose(got_q, q, rtol=1e-15)
    np.testing.assert_allclose(got_pose, pose, atol=1e-9)
    only_q, none = compensate.read_targets(targets_csv(tmp_path / "q.csv", q))
    np.testing.assert_allclose(only_q, q, rtol=1e-15)
    assert none is None


@pytest.mark.parametrize(
    ("content", "message"),
    [
        ("q1_rad,q2_rad\n0,0\n", "missing column(s) q3_rad, q4_rad, q5_rad, q6_rad"),
        (
            "q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,q6_rad,x_mm,y_mm\n0,0,0,0,0,0,1,2\n",
            "a pose needs all of x_mm, y_mm, z_mm, rx_rad, ry_rad, rz_rad",
        ),
        ("q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,q6_rad\n", "no targets"),
        # pandas would read the first q1_rad and call the second "q1_rad.1".
        (
            "q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,q6_rad,q1_rad,q6_rad\n0,0,0,0,0,0,1,1\n",
            "repeated column(s) q1_rad, q6_rad",
        ),
        (
            "q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,q6_rad\n0,0,0,0,0,0\n0,0,x,0,0,0\n",
            "line 3, q3_rad: 'x' is not a decimal number",
        ),
        (
            "q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,q6_rad\n0,0,0,0,0,0\n0,0,0,0,0,0\n0,0,0,nan,0,0\n",
            "line 4, q4_rad: 'nan' is not a decimal number",
        ),
        (
            "q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,q6_rad,x_mm,y_mm,z_mm,rx_rad,ry_rad,rz_rad\n"
            "0,0,0,0,0,0,1,2,3,0,0,0\n0,0,0,0,0,0,1,inf,3,0,0,0\n",
            "line 3, y_mm: 'inf' is not a decimal number",
        ),
        ("", "not a readable CSV (No columns to parse from file)"),
    ],
)
def test_bad_targets_files_are_refused_in_one_line(tmp_path, content, message):
    path = tmp_path / "t.csv"
    path.write_text(content)
    with pytest.raises(CalibrationError) as info:
        compensate.read_targets(path)
    assert str(info.value) == f"{path}: {message}"


def test_compensate_command_writes_every_target(tmp_path):
    cal = calibrated(seed=17)
    cal.save(tmp_path / "cal.json")
    q = work_cell(6, seed=18)
    targets_csv(tmp_path / "t.csv", q)
    done = cli("compensate", "cal.json", "t.csv", "-o", "out.csv", cwd=tmp_path)
    assert done.code == 0, done.stderr
    assert done.stderr == ""
    first, sizes = done.stdout.splitlines()
    assert first == "6 of 6 targets compensated; wrote out.csv"
    out = pd.read_csv(tmp_path / "out.csv")
    assert list(out.columns) == [
        "target", "status",
        "q1_rad", "q2_rad", "q3_rad", "q4_rad", "q5_rad", "q6_rad",
        "x_mm", "y_mm", "z_mm", "rx_rad", "ry_rad", "rz_rad",
        "correction_mm", "correction_mrad", "joint_correction_mrad",
        "iterations", "error_mm",
    ]  # fmt: skip
    assert out["target"].tolist() == [0, 1, 2, 3, 4, 5]  # as plans number their poses
    assert (out["status"] == "ok").all()
    joints = out[[f"q{i}_rad" for i in range(1, 7)]].to_numpy()
    desired = kinematics.chain(cal.nominal_mdh, q) @ cal.flange2tool
    reached = kinematics.chain(cal.mdh, joints) @ cal.flange2tool
    # 12 significant digits in the file: sub-micrometre on a metre-sized arm.
    np.testing.assert_allclose(reached[:, :3, 3], desired[:, :3, 3], rtol=0, atol=1e-5)
    sent = kinematics.chain(cal.nominal_mdh, joints) @ cal.flange2tool
    np.testing.assert_allclose(out[["x_mm", "y_mm", "z_mm"]].to_numpy(), sent[:, :3, 3], atol=1e-5)
    rv = out[["rx_rad", "ry_rad", "rz_rad"]].to_numpy()
    assert angle_between(rotations.rotvec_to_matrix(rv), sent[:, :3, :3]).max() < 1e-9
    assert (out["iterations"] >= 1).all() and (out["error_mm"] < inverse.TOL_MM).all()
    # Each correction's size: the sent target against the desired one, and the joints.
    moved = np.linalg.norm(sent[:, :3, 3] - desired[:, :3, 3], axis=1)
    np.testing.assert_allclose(out["correction_mm"], moved, rtol=1e-9, atol=1e-9)
    turned = angle_between(sent[:, :3, :3], desired[:, :3, :3])
    np.testing.assert_allclose(out["correction_mrad"], 1e3 * turned, rtol=1e-6, atol=1e-9)
    dq = 1e3 * np.abs(joints - q).max(axis=1)
    np.testing.assert_allclose(out["joint_correction_mrad"], dq, rtol=1e-9, atol=1e-6)
    assert moved.max() > 0.1  # a real correction, not zeros
    assert sizes == (
        f"corrections: up to {moved.max():.3f} mm and {1e3 * turned.max():.3f} mrad on the "
        f"targets, {dq.max():.3f} mrad on a joint"
    )


@pytest.mark.parametrize("n_out", [10, 11])
def test_compensate_command_reports_failures_on_stderr_with_exit_1(tmp_path, n_out):
    cal = calibrated(seed=19)
    cal.save(tmp_path / "cal.json")
    q = work_cell(n_out + 2, seed=20)
    pose = kinematics.chain(cal.nominal_mdh, q) @ cal.flange2tool
    pose[:n_out, 0, 3] += 5000.0  # out of reach
    targets_csv(tmp_path / "t.csv", q, pose)
    done = cli("compensate", "cal.json", "t.csv", "-o", "out.csv", cwd=tmp_path)
    assert done.code == 1 and done.stdout == ""
    lines = done.stderr.splitlines()
    assert lines[0] == f"2 of {n_out + 2} targets compensated; wrote out.csv"
    # The summary, at most ten targets, then how many more.
    more = ["... and 1 more (see the status column)"] if n_out == 11 else []
    assert lines[1].startswith("corrections: up to ")
    assert len(lines) == 12 + len(more) and lines[12:] == more
    for i, line in enumerate(lines[2:12]):
        assert line.startswith(f"target {i}: not reached (")
        # Out of reach the solver stretches the arm out: the elbow singularity is named.
        assert line.endswith((" iterations)", " deg from stretched)")), line
        count = int(line.rsplit(" after ", 1)[1].split()[0])
        assert 1 <= count <= inverse.MAX_ITER
    out = pd.read_csv(tmp_path / "out.csv")
    assert out["status"].tolist() == ["not reached"] * n_out + ["ok"] * 2
    failed = out.loc[: n_out - 1]
    assert failed[["q1_rad", "x_mm", "rz_rad"]].isna().all().all()
    assert out.loc[n_out:, ["q1_rad", "x_mm", "rz_rad"]].notna().all().all()
    assert (failed["error_mm"] > 2000.0).all()
    first = lines[2].split("(")[1]
    assert first.startswith(
        f"{out.loc[0, 'error_mm']:.3g} mm off after {out.loc[0, 'iterations']} "
    )


def test_run_never_writes_over_its_targets(tmp_path):
    cal = calibrated(seed=25)
    path = targets_csv(tmp_path / "t.csv", work_cell(2))
    before = path.read_bytes()
    with pytest.raises(CalibrationError, match="t.csv"):
        compensate.run(cal, path, path)
    assert path.read_bytes() == before and [p.name for p in tmp_path.iterdir()] == ["t.csv"]


def test_compensate_command_names_the_joints_past_their_limits(tmp_path):
    cal = calibrated(seed=21)
    cal.save(tmp_path / "cal.json")
    q = work_cell(3, seed=22)
    # Joints 1 and 6 at the ends of their travel the compensation goes past.
    ends = (2 * np.pi - 1e-7, -2 * np.pi + 1e-7)
    for end1, end6 in ((a, b) for a in ends for b in ends):
        q[1, [0, 5]] = end1, end6
        free = compensate.compensate(cal, q_nominal=q)
        if np.all(np.abs(free.q[1, [0, 5]]) > 2 * np.pi):
            break
    assert np.all(np.abs(free.q[1, [0, 5]]) > 2 * np.pi)
    assert np.all(np.abs(free.q[:, 1:5]) < np.pi)
    targets_csv(tmp_path / "t.csv", q)
    done = cli("compensate", "cal.json", "t.csv", "-o", "out.csv", cwd=tmp_path)
    assert done.code == 1
    lines = done.stderr.splitlines()
    assert lines[0] == "2 of 3 targets compensated; wrote out.csv"
    assert lines[1].startswith("corrections: up to ") and len(lines) == 3
    assert lines[2] == "target 1: unreachable within the joint limits (joint 1, 6)"
    out = pd.read_csv(tmp_path / "out.csv")
    assert out["status"].tolist() == ["ok", "outside joint limits", "ok"]


def test_an_arm_without_known_limits_says_so(tmp_path):
    cal = calibrated(seed=23, model=None)
    cal.save(tmp_path / "cal.json")
    q = work_cell(2, seed=24)
    q[0, 0] = 2 * np.pi + 1.0  # no limits: any angle goes
    targets_csv(tmp_path / "t.csv", q)
    done = cli("compensate", "cal.json", "t.csv", "-o", "out.csv", cwd=tmp_path)
    assert done.code == 0, done.stderr
    assert done.stdout.splitlines()[0] == (
        "2 of 2 targets compensated (no joint limits known for this model); wrote out.csv"
    )
    unknown = calibrated(seed=23, model="my-arm")
    unknown.save(tmp_path / "cal2.json")
    done = cli("compensate", "cal2.json", "t.csv", "-o", "out2.csv", cwd=tmp_path)
    assert done.code == 0 and "(no joint limits known for this model)" in done.stdout


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (("cal.json", "t.csv", "-o", "t.csv"), "t.csv"),
        (("cal.json", "missing.csv", "-o", "out.csv"), "missing.csv"),
        (("nope.json", "t.csv", "-o", "out.csv"), "calibration file not found: nope.json"),
        (("cal.json", "bad.csv", "-o", "out.csv"), "bad.csv: missing column(s) q3_rad"),
    ],
)
def test_compensate_command_refusals_are_one_line_and_write_nothing(tmp_path, args, words):
    calibrated().save(tmp_path / "cal.json")
    targets_csv(tmp_path / "t.csv", work_cell(2))
    (tmp_path / "bad.csv").write_text("q1_rad,q2_rad\n0,0\n")
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    line = one_line_error(cli("compensate", *args, cwd=tmp_path))
    assert words in line
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before
