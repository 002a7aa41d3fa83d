"""Fanuc LS: /POS positions with UF/UT/CONFIG, joint positions, a second group."""

import re

import numpy as np
from filter_kit import BASE, TOOL, calibration, frame_yaml, job, work_joints

from calibrator import compensate
from calibrator.filtering import engine, frames_file, rotations
from calibrator.filtering.fanuc import FanucLS
from calibrator.filtering.solve import Solver
from calibrator.model import frames, kinematics


def _frames_yaml(tmp_path):
    path = tmp_path / "frames.yaml"
    path.write_text(f"tools:\n  '1': {frame_yaml(TOOL)}\nbases:\n  '1': {frame_yaml(BASE)}\n")
    return frames_file.read(path)


def write_ls(path, cal, q):
    lang = FanucLS.__new__(FanucLS)
    codes = Solver(lang, job(cal)).code_of(q)
    poses = np.linalg.inv(BASE) @ compensate.tool_poses(cal.nominal_mdh, q, TOOL)
    out = [
        "/PROG  SCHWEISS", "/ATTR", "OWNER\t\t= MNEDITOR;", 'COMMENT\t\t= "Naht äöü";',
        "/MN", "   1:  UFRAME_NUM=1 ;", "   2:  UTOOL_NUM=1 ;",
    ]  # fmt: skip
    for i in range(len(q) + 1):
        out.append(
            f"   {i + 3}:{'J' if i == 0 else 'L'} P[{i + 1}] "
            f"{'100%' if i == 0 else '250mm/sec'} FINE    ;"
        )
    out += ["/POS", "P[1]{", "   GP1:", "\tUF : 1, UT : 1,\t"]
    out += ["\tJ1=     0.000 deg,\tJ2=    10.000 deg,\tJ3=   -10.000 deg,",
            "\tJ4=     0.000 deg,\tJ5=    45.000 deg,\tJ6=     0.000 deg", "};"]  # fmt: skip
    for i, (pose, c) in enumerate(zip(poses, codes, strict=True)):
        wpr = rotations.matrix_to_zyx(pose[None, :3, :3], np.zeros((1, 3)))[0][::-1]
        x, y, z = pose[:3, 3]
        conf = f"'{'NF'[c[0]]} {'UD'[c[1]]} {'TB'[c[2]]}, {c[3]}, {c[4]}, {c[5]}'"
        label = f'P[{i + 2}:"Naht {i}"]' if i % 2 else f"P[{i + 2}]"
        out += [
            label + "{", "   GP1:", f"\tUF : 1, UT : 1,\t\tCONFIG : {conf},",
            f"\tX = {x:9.3f}  mm,\tY = {y:9.3f}  mm,\tZ = {z:9.3f}  mm,",
            f"\tW = {wpr[0]:9.3f} deg,\tP = {wpr[1]:9.3f} deg,\tR = {wpr[2]:9.3f} deg",
        ]  # fmt: skip
        if i == 0:
            out += ["   GP2:", "\tUF : 1, UT : 1,", "\tJ1=    90.000 deg,\tJ2=     0.000 deg"]
        out.append("};")
    out += ["/END", ""]
    path.write_bytes("\r\n".join(out).encode("utf-8"))
    return path


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
    src = write_ls(tmp_path / "weld.ls", cal, work_joints(6))
    out = tmp_path / "out.ls"
    summary = engine.Filter("fanuc", job(cal, _frames_yaml(tmp_path)), src).run(out, [src])
    assert summary.n_failed == 0, summary.failures
    assert summary.corrected["pose"] == 6 and summary.kept["joints"] == 1
    assert out.read_bytes() == src.read_bytes()


def test_positions_land_and_the_second_group_is_kept(tmp_path):
    cal = calibration()
    q = work_joints(6)
    src = write_ls(tmp_path / "weld.ls", cal, q)
    out = tmp_path / "out.ls"
    summary = engine.Filter("fanuc", job(cal, _frames_yaml(tmp_path)), src).run(out, [src])
    assert summary.n_failed == 0, summary.failures
    text = out.read_bytes().decode()
    before = src.read_bytes().decode()
    changed = [a for a, b in zip(before.split("\r\n"), text.split("\r\n"), strict=True) if a != b]
    assert len(changed) == 12 and all(("X =" in c or "W =" in c) for c in changed)
    sent = BASE @ _read(text)
    nominal = compensate.inverse(cal.nominal_mdh, sent, q, TOOL)
    landed = kinematics.chain(cal.mdh, nominal.q) @ TOOL
    intended = BASE @ _read(before)
    assert np.linalg.norm(landed[:, :3, 3] - intended[:, :3, 3], axis=1).max() < 0.01


def test_configuration_change_is_named_with_its_line(tmp_path):
    cal = calibration()
    q = work_joints(6)
    q[2, 5] = np.radians(-179.995)  # joint 6 at the turn boundary: the calibrated arm crosses it
    src = write_ls(tmp_path / "weld.ls", cal, q)
    summary = engine.Filter("fanuc", job(cal, _frames_yaml(tmp_path)), src).run(
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
    src = write_ls(tmp_path / "weld.ls", cal, q)
    summary = engine.Filter("fanuc", job(cal, _frames_yaml(tmp_path)), src).run(
        tmp_path / "o.ls", [src]
    )
    (fail,) = summary.failures
    assert fail["target"] == "P[6]" and "cannot reach" in fail["reason"]
    assert src.read_bytes().decode().split("\r\n")[fail["line"] - 1].startswith("\tX =")
