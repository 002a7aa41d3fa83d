"""RAPID: tooldata, wobjdata, robtargets and jointtargets as ABB's reference writes them."""

import re

import numpy as np
from filter_kit import BASE, TOOL, TOOL2, calibration, job, work_joints
from program_kit import write_rapid_module

from calibrator.compensate import programs
from calibrator.model import inverse, kinematics, rotations


def _read(text):
    pat = re.compile(
        r"\[\[([-\d.]+),([-\d.]+),([-\d.]+)\],\[([-\d.]+),([-\d.]+),([-\d.]+),([-\d.]+)\],\["
    )
    text = text.replace("\r\n      ", "")  # the declaration over two lines
    keep = "".join(line for line in text.splitlines() if "robtarget" in line or "MoveJ [" in line)
    return np.array([[float(x) for x in m.groups()] for m in pat.finditer(keep)])


def test_identity_round_trip_is_byte_for_byte(tmp_path):
    cal = calibration(mm=0, rad=0)
    src = write_rapid_module(tmp_path / "Zelle3.mod", cal, work_joints(8))
    out = tmp_path / "out.mod"
    summary = programs.Filter("rapid", job(cal), src).run(out, [src])
    assert summary.n_failed == 0, summary.failures
    assert summary.corrected["pose"] == 8 and summary.kept["joints"] == 1
    assert out.read_bytes() == src.read_bytes()


def test_filtered_targets_land_in_their_work_object(tmp_path):
    cal = calibration()
    q = work_joints(8)
    src = write_rapid_module(tmp_path / "Zelle3.mod", cal, q)
    out = tmp_path / "out.mod"
    summary = programs.Filter("rapid", job(cal), src).run(out, [src])
    assert summary.n_failed == 0, summary.failures
    before, after = src.read_bytes().split(b"\r\n"), out.read_bytes().split(b"\r\n")
    changed = [i for i, (a, b) in enumerate(zip(before, after, strict=True)) if a != b]
    assert changed == [6, 7, 8, 9, 10, 17, 18, 19, 20]
    v = _read(out.read_bytes().decode("utf-8"))
    from calibrator.model import frames

    written = frames.transform(rotations.quaternion_to_matrix(v[:, 3:]), v[:, :3])
    bases = np.array([BASE] * 4 + [np.eye(4)] * 4)
    tools = np.array([TOOL] * 4 + [TOOL2] * 4)
    nominal = inverse.solve(cal.nominal_mdh, bases @ written, q, tools)
    landed = kinematics.chain(cal.mdh, nominal.q) @ tools
    v0 = _read(src.read_bytes().decode("utf-8"))  # the poses as the program states them
    intended = bases @ frames.transform(rotations.quaternion_to_matrix(v0[:, 3:]), v0[:, :3])
    assert np.linalg.norm(landed[:, :3, 3] - intended[:, :3, 3], axis=1).max() < 0.01
    turn = np.linalg.norm(
        rotations.matrix_to_zyx(
            landed[:, :3, :3] @ np.swapaxes(intended[:, :3, :3], 1, 2), np.zeros((8, 3))
        ),
        axis=1,
    )
    assert turn.max() < 0.002


def test_configuration_change_and_unreachable_are_named(tmp_path):
    cal = calibration()
    q = work_joints(8)
    q[1, 0] = np.radians(0.01)  # axis 1 at the edge of quadrant 0: calibrated needs -1
    q[2, 2] = np.radians(-82.5) + 0.005  # stretched out: out of the calibrated arm's reach
    q[2, 1] = 0.3
    src = write_rapid_module(tmp_path / "Zelle3.mod", cal, q)
    out = tmp_path / "out.mod"
    summary = programs.Filter("rapid", job(cal), src).run(out, [src])
    reasons = {f["line"]: f["reason"] for f in summary.failures}
    assert set(reasons) == {8, 9}, reasons
    assert reasons[8].startswith("the configuration would change from [0,")
    assert "cannot reach" in reasons[9]
    assert not out.exists()
