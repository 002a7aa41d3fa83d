"""Yaskawa JBI: pulse and RECTAN positions, TOOL/USER frames, RCONF."""

import re

import numpy as np
from filter_kit import BASE, TOOL, calibration, frame_yaml, job, work_joints
from program_kit import PPD, write_jbi_job

from calibrator.compensate import programs
from calibrator.languages import frames_file
from calibrator.model import frames, inverse, kinematics, rotations


def _frames(tmp_path):
    path = tmp_path / "frames.yaml"
    path.write_text(
        f"tools:\n  '1': {frame_yaml(TOOL)}\nbases:\n  '2': {frame_yaml(BASE)}\n"
        f"pulses_per_degree: {PPD}\n"
    )
    return frames_file.read(path)


def _read(text):
    rows = re.findall(r"^C000(?:0[1-9]|[1-9]\d)=(.*)$", text, re.M)
    v = np.array([[float(x) for x in r.split(",")] for r in rows])
    return frames.transform(rotations.zyx_to_matrix(v[:, [5, 4, 3]]), v[:, :3])


def test_identity_round_trip_is_byte_for_byte(tmp_path):
    cal = calibration(mm=0, rad=0)
    src = write_jbi_job(tmp_path / "NAHT1.JBI", cal, work_joints(6))
    out = tmp_path / "OUT.JBI"
    summary = programs.Filter("jbi", job(cal, _frames(tmp_path)), src).run(out, [src])
    assert summary.n_failed == 0, summary.failures
    assert summary.corrected["pose"] == 6 and summary.kept["joints"] == 1
    assert out.read_bytes() == src.read_bytes()


def test_rectan_positions_land_in_the_user_frame(tmp_path):
    cal = calibration()
    q = work_joints(6)
    src = write_jbi_job(tmp_path / "NAHT1.JBI", cal, q)
    out = tmp_path / "OUT.JBI"
    summary = programs.Filter("jbi", job(cal, _frames(tmp_path)), src).run(out, [src])
    assert summary.n_failed == 0, summary.failures
    text, before = out.read_bytes().decode(), src.read_bytes().decode()
    changed = [a for a, b in zip(before.split("\r\n"), text.split("\r\n"), strict=True) if a != b]
    assert len(changed) == 6 and all(c.startswith("C0000") for c in changed)
    nominal = inverse.solve(cal.nominal_mdh, BASE @ _read(text.replace("\r\n", "\n")), q, TOOL)
    landed = kinematics.chain(cal.mdh, nominal.q) @ TOOL
    intended = BASE @ _read(before.replace("\r\n", "\n"))
    assert np.linalg.norm(landed[:, :3, 3] - intended[:, :3, 3], axis=1).max() < 0.01


def test_pulse_positions_are_corrected_when_asked(tmp_path):
    cal = calibration()
    src = write_jbi_job(tmp_path / "NAHT1.JBI", cal, work_joints(2))
    out = tmp_path / "OUT.JBI"
    summary = programs.Filter("jbi", job(cal, _frames(tmp_path), correct_joints=True), src).run(
        out, [src]
    )
    assert summary.n_failed == 0 and summary.corrected["joints"] == 1
    home = [int(v) for v in re.search(r"C00000=(.*)", out.read_text()).group(1).split(",")]
    q = np.radians(np.array(home) / PPD)
    reached = kinematics.chain(cal.mdh, q[None]) @ TOOL
    wanted = kinematics.chain(cal.nominal_mdh, np.radians([[0, 10, -10, 0, 45, 0]])) @ TOOL
    # One pulse is a few thousandths of a degree: within 0.05 mm at this reach.
    assert np.linalg.norm(reached[0, :3, 3] - wanted[0, :3, 3]) < 0.05
    missing = frames_file.FrameTable(tools=_frames(tmp_path).tools, bases=_frames(tmp_path).bases)
    summary = programs.Filter("jbi", job(cal, missing, correct_joints=True), src).run(out, [src])
    assert summary.failures[0]["reason"] == "pulse positions need pulses_per_degree in --frames"


def test_configuration_change_is_named_with_its_line(tmp_path):
    # A UR10e model (joint 6 turns +-360 deg), so the half-turn flag can change
    # inside the limits.
    cal = calibration("ur10e", mm=0.3, rad=0.002)
    q = work_joints(6, model="ur10e")
    q[1, 5] = np.radians(-179.95)  # joint 6 at its half-turn flag: the calibrated arm crosses it
    src = write_jbi_job(tmp_path / "NAHT1.JBI", cal, q)
    summary = programs.Filter("jbi", job(cal, _frames(tmp_path)), src).run(
        tmp_path / "O.JBI", [src]
    )
    (fail,) = summary.failures
    assert fail["target"] == "C00002"
    assert fail["reason"].startswith("the configuration would change from RCONF 0,0,1,0,0,0 to ")
    assert src.read_bytes().decode().split("\r\n")[fail["line"] - 1].startswith("C00002=")
    assert not (tmp_path / "O.JBI").exists()


def test_unreachable_position_is_named_with_its_line(tmp_path):
    cal = calibration()
    q = work_joints(6)
    q[3, 1], q[3, 2] = 0.3, np.radians(-82.5) + 0.005  # the arm stretched out
    src = write_jbi_job(tmp_path / "NAHT1.JBI", cal, q)
    summary = programs.Filter("jbi", job(cal, _frames(tmp_path)), src).run(
        tmp_path / "O.JBI", [src]
    )
    (fail,) = summary.failures
    assert fail["target"] == "C00004" and "cannot reach" in fail["reason"]
    assert src.read_bytes().decode().split("\r\n")[fail["line"] - 1].startswith("C00004=")
