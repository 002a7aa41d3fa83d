"""KRL: a .src with its .dat, from KUKA's expert programming manual's forms."""

import re

import numpy as np
from filter_kit import BASE, TOOL, TOOL2, calibration, frame_yaml, job, poses, work_joints
from program_kit import krl_frame, krl_status_turn, write_krl_program

from calibrator.compensate import programs
from calibrator.languages import frames_file
from calibrator.model import frames, inverse, kinematics, rotations


def test_identity_calibration_is_byte_for_byte(tmp_path):
    cal = calibration(mm=0, rad=0)
    src, config = write_krl_program(tmp_path, cal, work_joints(12))
    out = tmp_path / "out" / "weld.src"
    out.parent.mkdir()
    summary = programs.Filter("krl", job(cal, config_dat=config), src).run(out, [src])
    assert summary.n_failed == 0, summary.failures
    assert summary.corrected["pose"] == 12
    assert out.read_bytes() == src.read_bytes()
    assert out.with_suffix(".dat").read_bytes() == src.with_suffix(".dat").read_bytes()


def _read_poses(text):
    """Every full X..C aggregate of a text, in order (an independent regex reading)."""
    pat = re.compile(r"X ([-\d.]+),Y ([-\d.]+),Z ([-\d.]+),A ([-\d.]+),B ([-\d.]+),C ([-\d.]+)")
    v = np.array([[float(x) for x in m.groups()] for m in pat.finditer(text)])
    return frames.transform(rotations.zyx_to_matrix(v[:, 3:]), v[:, :3])


def test_corrected_targets_land_on_the_intended_pose(tmp_path):
    cal = calibration()
    q = work_joints(12)
    src, config = write_krl_program(tmp_path, cal, q)
    out = tmp_path / "o.src"
    summary = programs.Filter("krl", job(cal, config_dat=config), src).run(out, [src])
    assert summary.n_failed == 0, summary.failures
    before = src.read_bytes().decode("cp1252").splitlines(keepends=True)
    after = out.read_bytes().decode("cp1252").splitlines(keepends=True)
    assert len(before) == len(after) and all(a.endswith("\r\n") for a in after)
    # Only target lines changed; comments and everything else byte for byte.
    changed = [i for i, (a, b) in enumerate(zip(before, after, strict=False)) if a != b]
    assert all("LIN {" in before[i] for i in changed) and len(changed) == 6
    assert after[2] == before[2]
    dat = out.with_suffix(".dat").read_bytes().decode("cp1252")
    written = np.concatenate([_read_poses(dat), _read_poses("".join(after[8:]))])
    tools = np.array([TOOL] * 6 + [TOOL2] * 6)
    bases = np.array([BASE] * 6 + [np.eye(4)] * 6)
    intended = kinematics.tool_poses(cal.nominal_mdh, q, tools)
    # The nominal controller (its IK, same configuration) drives the true arm.
    sent = bases @ written
    nominal = inverse.solve(cal.nominal_mdh, sent, q, tools)
    assert nominal.converged.all()
    true_pose = kinematics.chain(cal.mdh, nominal.q) @ tools
    err = np.linalg.norm(true_pose[:, :3, 3] - intended[:, :3, 3], axis=1)
    assert err.max() < 0.01, err
    unfiltered = kinematics.chain(cal.mdh, q) @ tools
    assert np.linalg.norm(unfiltered[:, :3, 3] - intended[:, :3, 3], axis=1).min() > 0.3


def _one_target(tmp_path, cal, q, st=None):
    pose = poses(cal, q[None], TOOL, np.eye(4))[0]
    src = tmp_path / "one.src"
    src.write_text(
        "DEF ONE()\n$TOOL = TOOL_DATA[1]\n$BASE = BASE_DATA[0]\n; the target\n"
        f"LIN {{{krl_frame(pose)},{st or krl_status_turn(q)}}}\nEND\n"
    )
    frames_yaml = tmp_path / "frames.yaml"
    frames_yaml.write_text(f"tools:\n  '1': {frame_yaml(TOOL)}\n")
    return src, frames_file.read(frames_yaml)


def test_unreachable_target_is_named_with_its_line(tmp_path):
    cal = calibration()
    q = np.array([0.2, 0.3, np.radians(-82.5) + 0.005, 0.3, 0.8, 0.1])  # arm stretched out
    src, table = _one_target(tmp_path, cal, q)
    out = tmp_path / "o.src"
    summary = programs.Filter("krl", job(cal, table), src).run(out, [src])
    assert not out.exists()
    (fail,) = summary.failures
    assert fail["line"] == 5 and "cannot reach" in fail["reason"]
    assert "elbow singularity" in fail["reason"]


def test_configuration_that_cannot_be_kept_is_named(tmp_path):
    cal = calibration()
    # Axis 1 a hair above zero: the calibrated arm needs it below (turn bit T of A1).
    q = np.array([np.radians(0.01), 0.3, -0.2, 0.3, 0.8, 0.1])
    src, table = _one_target(tmp_path, cal, q)
    summary = programs.Filter("krl", job(cal, table), src).run(tmp_path / "o.src", [src])
    (fail,) = summary.failures
    assert fail["line"] == 5
    assert "configuration would change from S 2 T 4 to S 2 T 5" in fail["reason"], fail


def test_wrist_swing_near_singularity_is_refused(tmp_path):
    cal = calibration()
    q = np.array([0.2, 0.3, -0.2, 0.3, np.radians(0.02), 0.1])
    src, table = _one_target(tmp_path, cal, q)
    summary = programs.Filter("krl", job(cal, table), src).run(tmp_path / "o.src", [src])
    (fail,) = summary.failures
    assert "would turn" in fail["reason"] and "wrist singularity" in fail["reason"]


def test_keep_failed_writes_and_marks(tmp_path):
    cal = calibration()
    q = np.array([0.2, 0.3, np.radians(-82.5) + 0.005, 0.3, 0.8, 0.1])
    src, table = _one_target(tmp_path, cal, q)
    out = tmp_path / "o.src"
    programs.Filter("krl", job(cal, table, keep_failed=True), src).run(out, [src])
    lines = out.read_text().splitlines()
    assert lines[4].startswith(src.read_text().splitlines()[4] + " ; not corrected: ")
    assert out.read_text().splitlines()[:4] == src.read_text().splitlines()[:4]


def test_undefined_tool_fails_its_targets(tmp_path):
    cal = calibration()
    src, _ = _one_target(tmp_path, cal, work_joints(1)[0])
    summary = programs.Filter("krl", job(cal), src).run(tmp_path / "o.src", [src])
    (fail,) = summary.failures
    assert "TOOL_DATA[1] is defined neither" in fail["reason"]


def test_max_correction_refuses_a_large_one(tmp_path):
    cal = calibration()
    src, table = _one_target(tmp_path, cal, work_joints(1)[0])
    summary = programs.Filter("krl", job(cal, table, max_mm=0.01), src).run(
        tmp_path / "o.src", [src]
    )
    (fail,) = summary.failures
    assert "exceeds --max-correction 0.01,0.5" in fail["reason"]


def test_joint_targets_are_kept_or_corrected(tmp_path):
    cal = calibration()
    src, config = write_krl_program(tmp_path, cal, work_joints(4))
    kept = programs.Filter("krl", job(cal, config_dat=config), src).run(tmp_path / "k.src", [src])
    assert kept.kept["joints"] == 2 and kept.corrected["joints"] == 0  # HOMEPOS and the inline PTP
    out = tmp_path / "c.src"
    fixed = programs.Filter("krl", job(cal, config_dat=config, correct_joints=True), src).run(
        out, [src]
    )
    assert fixed.n_failed == 0 and fixed.corrected["joints"] == 2
    home = re.search(r"HOMEPOS = \{(.*)\}", out.read_text("cp1252")).group(1)
    q = np.radians([[float(v.split()[1]) for v in home.split(",")]])
    # The calibrated arm at the new joints reaches the nominal pose of the old ones (tool 1).
    wanted = kinematics.chain(cal.nominal_mdh, np.radians([[0, -10, 10, 0, 45, 0]])) @ TOOL
    reached = kinematics.chain(cal.mdh, q) @ TOOL
    assert np.linalg.norm(reached[0, :3, 3] - wanted[0, :3, 3]) < 0.01
    assert src.read_text("cp1252").count("HOMEPOS") == out.read_text("cp1252").count("HOMEPOS")
