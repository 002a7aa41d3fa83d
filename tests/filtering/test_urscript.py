"""URScript: set_tcp, pose literals and variables, joint lists (URScript manual forms)."""

import json
import re

import numpy as np
from cli_process_kit import run_cli
from filter_kit import calibration, job, path_joints
from program_kit import TCP, write_urscript

from calibrator.compensate import programs
from calibrator.model import frames, inverse, kinematics, rotations


def test_identity_round_trip_is_byte_for_byte(tmp_path):
    cal = calibration("ur10e", mm=0, rad=0)
    src = write_urscript(tmp_path / "prog.script", cal, path_joints(10, model="ur10e"))
    out = tmp_path / "out.script"
    summary = programs.Filter("urscript", job(cal), src).run(out, [src])
    assert summary.n_failed == 0, summary.failures
    assert summary.corrected["pose"] == 9 and summary.kept["joints"] == 1
    assert out.read_bytes() == src.read_bytes()


def test_filtered_poses_land_and_nothing_else_changes(tmp_path):
    cal = calibration("ur10e")
    q = path_joints(10, model="ur10e")
    src = write_urscript(tmp_path / "prog.script", cal, q)
    out = tmp_path / "out.script"
    summary = programs.Filter("urscript", job(cal), src).run(out, [src])
    assert summary.n_failed == 0, summary.failures
    before, after = src.read_bytes().split(b"\r\n"), out.read_bytes().split(b"\r\n")
    same = [i for i, (a, b) in enumerate(zip(before, after, strict=False)) if a == b]
    assert same == [0, 1, 2, 3, 5, 14, 15, 16]  # only the pose lines changed
    pat = r"p\[([^\]]*)\]"
    found = [re.search(pat, after[i].decode()).group(1) for i in [4] + list(range(6, 14))]
    v = np.array([[float(x) for x in f.split(",")] for f in found])
    sent = frames.transform(rotations.rotvec_to_matrix(v[:, 3:]), 1000 * v[:, :3])
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


def test_plain_lines_read_as_the_general_path_reads_them(tmp_path, monkeypatch):
    from dataclasses import replace

    from calibrator.languages.urscript import reader as urscript

    nums = "0.5, -0.25, +0.125, .75, 3., 1"
    lines = [
        f"  movel(p[{nums}], a=1.2, v=0.25)\r\n",
        f"  approach = p[{nums}]\n",  # a variable's own line, then plain lines again
        "  movel(approach)\n",
        f"movej([{nums}])\n",
        f"\tmovep( p [ {nums} ] ,r=0.001 )\r",
        f"  movel(p[{nums}], a=1.2) # a comment\n",
        f"  movel(p[{nums}] x)\n",  # not a call of one literal: fails as cut off
        f"  movel(p[{nums}, 2])\n",  # seven values
        "  movel(p[0.5, 1e3, 0, 0, 0, 0])\n",  # an exponent: the grammar's own path
        "  movel(p[0.5, 1.2.3, 0, 0, 0, 0])\n",
        "  movel(p[0.5, 123456789012345678901, 0, 0, 0, 0])\n",
        f'  movel(p[{nums}], a="(")\n',
        f"  xmovel(p[{nums}])\n",
        f"  movec(p[{nums}], p[{nums}], a=1)\n",
        f"  movel(p[{nums}], a=f(1))\n",
        "  set_tcp(p[0, 0, 0.1, 0, 0, 0])\n",
        f"  movel(p[{nums}])",  # under the new TCP, no line ending (the last line)
    ]
    src = tmp_path / "lines.script"
    src.write_bytes("".join(lines).encode("latin-1"))
    cal = calibration("ur10e")

    def targets():
        lang = urscript.URScript(job(cal), src)
        return [(u.lines, u.targets) for u in lang.scan(src)]

    plain = targets()
    monkeypatch.setattr(urscript, "_PLAIN_MOVE", re.compile("(?!)"))  # never matches
    general = targets()
    assert len(plain) == len(lines)
    for (lines_a, targets_a), (lines_b, targets_b) in zip(plain, general, strict=True):
        assert lines_a == lines_b
        assert len(targets_a) == len(targets_b)
        for a, b in zip(targets_a, targets_b, strict=True):
            tools = (a.tool, b.tool)
            assert replace(a, tool=None) == replace(b, tool=None)
            assert (tools[0] is None and tools[1] is None) or np.array_equal(*tools)
    assert [t.problem for _, ts in plain[:5] + plain[-1:] for t in ts] == [None] * 5
    assert {t.file for _, ts in plain for t in ts} == {str(src)}
    assert plain[-1][1][0].tool[2, 3] == 100.0
