"""A program longer than a block is filtered as if it were one block.

The filter reads targets in blocks (:data:`calibrator.compensate.programs.BLOCK`)
and carries the joints the arm comes from across each block's end: a
URScript pose at the start of a block is solved from the last target of the
block before, as the controller would. Filtered in blocks of 2, 3 and 5
targets, a program is written byte for byte as in one block, and every pose
lands on the true arm.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from filter_kit import calibration, job, path_joints

from calibrator.compensate import programs
from calibrator.model import frames, inverse, kinematics, rotations

TCP = frames.transform(rotations.rotvec_to_matrix([0.0, 0.3, 0.0]), [0.0, 15.0, 160.0])


def _p(pose):
    rv = rotations.matrix_to_rotvec(pose[:3, :3])
    x, y, z = pose[:3, 3] / 1000.0
    return f"p[{x:.9f}, {y:.9f}, {z:.9f}, {rv[0]:.9f}, {rv[1]:.9f}, {rv[2]:.9f}]"


@pytest.mark.parametrize("block", [2, 3, 5])
def test_a_program_filtered_in_blocks_is_the_program_filtered_whole(tmp_path, monkeypatch, block):
    cal = calibration("ur10e", seed=4)
    q = path_joints(9, seed=3, model="ur10e")
    poses = kinematics.tool_poses(cal.nominal_mdh, q, TCP)
    lines = ["def path():", f"  set_tcp({_p(TCP)})"]
    lines.append("  movej([" + ", ".join(f"{v:.9f}" for v in q[0]) + "], a=1.2, v=0.25)")
    lines += [f"  movel({_p(p)}, a=1.2, v=0.25)" for p in poses[1:]]
    src = tmp_path / "path.script"
    src.write_text("\n".join([*lines, "end", ""]))
    whole = programs.Filter("urscript", job(cal), src).run(tmp_path / "whole.script", [src])
    assert whole.n_failed == 0 and whole.corrected["pose"] == len(q) - 1
    monkeypatch.setattr(programs, "BLOCK", block)
    parts = programs.Filter("urscript", job(cal), src).run(tmp_path / "parts.script", [src])
    assert parts.n_failed == 0, parts.failures
    text = (tmp_path / "parts.script").read_text()
    assert text == (tmp_path / "whole.script").read_text()
    # And each pose lands, solved from the joints of the target before it.
    rows = re.findall(r"movel\(p\[([^\]]*)\]", text)
    w = np.array([[float(v) for v in r.split(",")] for r in rows])
    sent = frames.transform(rotations.rotvec_to_matrix(w[:, 3:]), 1000.0 * w[:, :3])
    nominal = inverse.solve(cal.nominal_mdh, sent, q[:-1], TCP)
    assert nominal.converged.all()
    reached = kinematics.chain(cal.mdh, nominal.q) @ TCP
    assert np.linalg.norm(reached[:, :3, 3] - poses[1:, :3, 3], axis=1).max() < 0.02
