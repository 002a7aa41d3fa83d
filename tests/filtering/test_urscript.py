"""URScript: set_tcp, pose literals and variables, joint lists (URScript manual forms)."""

import json
import re

import numpy as np
from cli_process_kit import run_cli
from filter_kit import calibration, job, path_joints
from program_kit import TCP, write_urscript

from calibrator.filtering import engine
from calibrator.model import frames, inverse, kinematics


def test_identity_round_trip_is_byte_for_byte(tmp_path):
    cal = calibration("ur10e", mm=0, rad=0)
    src = write_urscript(tmp_path / "prog.script", cal, path_joints(10, model="ur10e"))
    out = tmp_path / "out.script"
    summary = engine.Filter("urscript", job(cal), src).run(out, [src])
    assert summary.n_failed == 0, summary.failures
    assert summary.corrected["pose"] == 9 and summary.kept["joints"] == 1
    assert out.read_bytes() == src.read_bytes()


def test_filtered_poses_land_and_nothing_else_changes(tmp_path):
    cal = calibration("ur10e")
    q = path_joints(10, model="ur10e")
    src = write_urscript(tmp_path / "prog.script", cal, q)
    out = tmp_path / "out.script"
    summary = engine.Filter("urscript", job(cal), src).run(out, [src])
    assert summary.n_failed == 0, summary.failures
    before, after = src.read_bytes().split(b"\r\n"), out.read_bytes().split(b"\r\n")
    same = [i for i, (a, b) in enumerate(zip(before, after, strict=False)) if a == b]
    assert same == [0, 1, 2, 3, 5, 14, 15, 16]  # only the pose lines changed
    pat = r"p\[([^\]]*)\]"
    found = [re.search(pat, after[i].decode()).group(1) for i in [4] + list(range(6, 14))]
    v = np.array([[float(x) for x in f.split(",")] for f in found])
    sent = frames.transform(frames.rotvec_to_matrix(v[:, 3:]), 1000 * v[:, :3])
    nominal = inverse.solve(cal.nominal_mdh, sent, q[1:], TCP)
    true_pose = kinematics.chain(cal.mdh, nominal.q) @ TCP
    intended = kinematics.tool_poses(cal.nominal_mdh, q[1:], TCP)
    err = np.linalg.norm(true_pose[:, :3, 3] - intended[:, :3, 3], axis=1)
    assert err.max() < 0.01


def test_cli_writes_summary_and_refuses_a_variable_under_two_tcps(tmp_path):
    cal = calibration("ur10e")
    cal.save(tmp_path / "cal.json")
    src = write_urscript(tmp_path / "prog.script", cal, path_joints(6, model="ur10e"))
    ok = run_cli(
        "compensate", "cal.json", "prog.script", "-o", "out.script", "--summary", "s.json",
        cwd=tmp_path,
    )  # fmt: skip
    assert ok.returncode == 0, ok.stderr
    doc = json.loads((tmp_path / "s.json").read_text())
    assert doc["targets"]["pose"] == {"found": 5, "corrected": 5, "kept": 0, "failed": 0}
    assert 0 < doc["correction"]["max_mm"] < 5 and "5 pose target(s)" in ok.stdout
    text = src.read_text().replace(
        "  movej(approach", "  set_tcp(p[0,0,0.1,0,0,0])\r\n  movej(approach"
    )
    (tmp_path / "two.script").write_bytes(text.encode())
    bad = run_cli("compensate", "cal.json", "two.script", "-o", "two_out.script", cwd=tmp_path)
    assert bad.returncode == 2 and "approach is moved to with the TCP" in bad.stderr
    assert not (tmp_path / "two_out.script").exists()
