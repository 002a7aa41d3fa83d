"""Fanuc LS: /POS positions with UF/UT/CONFIG, joint positions, a second group."""

import re

import numpy as np
from filter_kit import BASE, TOOL, calibration, frame_yaml, job, work_joints
from program_kit import write_fanuc_ls

from calibrator.compensate import programs
from calibrator.languages import frames_file
from calibrator.model import frames, inverse, kinematics, rotations


def _frames_yaml(tmp_path):
    path = tmp_path / "frames.yaml"
    path.write_text(f"tools:\n  '1': {frame_yaml(TOOL)}\nbases:\n  '1': {frame_yaml(BASE)}\n")
    return frames_file.read(path)


def _read(text):
    num = r"\s*([-\d.]+)"
    pat = (
        rf"X ={num}\s+mm,\tY ={num}\s+mm,\tZ ={num}\s+mm,\r\n"
        rf"\tW ={num} deg,\tP ={num} deg,\tR ={num} deg"
    )
    v = np.array([[float(x) for x in m.groups()] for m in re.finditer(pat, text)])
    return frames.transform(rotations.zyx_to_matrix(v[:, [5, 4, 3]]), v[:, :3])


def test_identity_round_trip_is_byte_for_byte(tmp_path):
    cal = calibration(mm=0, rad=0)
    src = write_fanuc_ls(tmp_path / "weld.ls", cal, work_joints(6))
    out = tmp_path / "out.ls"
    summary = programs.Filter("fanuc", job(cal, _frames_yaml(tmp_path)), src).run(out, [src])
    assert summary.n_failed == 0, summary.failures
    assert summary.corrected["pose"] == 6 and summary.kept["joints"] == 1
    assert out.read_bytes() == src.read_bytes()


def test_positions_land_and_the_second_group_is_kept(tmp_path):
    cal = calibration()
    q = work_joints(6)
    src = write_fanuc_ls(tmp_path / "weld.ls", cal, q)
    out = tmp_path / "out.ls"
    summary = programs.Filter("fanuc", job(cal, _frames_yaml(tmp_path)), src).run(out, [src])
    assert summary.n_failed == 0, summary.failures
    text = out.read_bytes().decode()
    before = src.read_bytes().decode()
    changed = [a for a, b in zip(before.split("\r\n"), text.split("\r\n"), strict=True) if a != b]
    assert len(changed) == 12 and all(("X =" in c or "W =" in c) for c in changed)
    sent = BASE @ _read(text)
    nominal = inverse.solve(cal.nominal_mdh, sent, q, TOOL)
    landed = kinematics.chain(cal.mdh, nominal.q) @ TOOL
    intended = BASE @ _read(before)
    assert np.linalg.norm(landed[:, :3, 3] - intended[:, :3, 3], axis=1).max() < 0.01


def test_configuration_change_is_named_with_its_line(tmp_path):
    cal = calibration()
    q = work_joints(6)
    q[2, 5] = np.radians(-179.995)  # joint 6 at the turn boundary: the calibrated arm crosses it
    src = write_fanuc_ls(tmp_path / "weld.ls", cal, q)
    summary = programs.Filter("fanuc", job(cal, _frames_yaml(tmp_path)), src).run(
        tmp_path / "o.ls", [src]
    )
    (fail,) = summary.failures
    line = src.read_bytes().decode().split("\r\n")[fail["line"] - 1]
    assert fail["target"] == "P[4]" and line.startswith("\tX =")
    assert "configuration would change" in fail["reason"], fail


def test_unreachable_position_is_named_with_its_line(tmp_path):
    cal = calibration()
    q = work_joints(6)
    q[4, 1], q[4, 2] = 0.3, np.radians(-82.5) + 0.005  # the arm stretched out
    src = write_fanuc_ls(tmp_path / "weld.ls", cal, q)
    summary = programs.Filter("fanuc", job(cal, _frames_yaml(tmp_path)), src).run(
        tmp_path / "o.ls", [src]
    )
    (fail,) = summary.failures
    assert fail["target"] == "P[6]" and "cannot reach" in fail["reason"]
    assert src.read_bytes().decode().split("\r\n")[fail["line"] - 1].startswith("\tX =")
