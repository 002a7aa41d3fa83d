"""RAPID ``MoveC``: both its points, in a tool and work object that only ``--frames`` defines.

``MoveC cirpoint, topoint, speed, zone, tool\\WObj:=wobj;`` has two targets,
so its tool is its fifth argument, not its fourth. A tool or work object
the module does not declare comes from ``--frames`` (``tools`` for a tool,
``bases`` for a work object). Each point of each arc lands on the simulated
true arm within 0.02 mm.
"""

from __future__ import annotations

import re

import config_kit as kit
import numpy as np
from filter_kit import calibration, frame_yaml, job
from program_kit import rapid_pose

from calibrator import robots
from calibrator.compensate import programs
from calibrator.languages import frames_file
from calibrator.model import frames, inverse, kinematics, rotations

LANDS_MM = 0.02
MODEL = "abb-irb4600-60-205"


def test_both_points_of_movec_land_in_the_tool_and_work_object_of_the_frames_file(tmp_path):
    arm = robots.get(MODEL)
    q, codes = kit.space(MODEL, kit.CODES[kit.RAPID])
    q, codes = q[:4], codes[:4]
    cal = calibration(model=MODEL, seed=11, mm=0.3, rad=0.0005)
    cb, cf = arm.model_base2controller_base, arm.model_flange2controller_flange
    taught = frames.invert(cb @ kit.USER) @ kinematics.chain(cal.nominal_mdh, q) @ cf @ kit.TOOL
    text = [
        rapid_pose(p)[:-1] + f",[{c[0]},{c[1]},{c[2]},{c[3]}],[9E9,9E9,9E9,9E9,9E9,9E9]]"
        for p, c in zip(taught, codes, strict=True)
    ]
    src = tmp_path / "arcs.mod"
    src.write_text(
        "MODULE Arcs\n"
        f"  CONST robtarget pVia:={text[0]};\n"
        f"  CONST robtarget pEnd:={text[1]};\n"
        "  PROC main()\n"
        "    MoveC pVia, pEnd, v100, z10, tGun\\WObj:=wTable;\n"
        f"    MoveC {text[2]}, {text[3]}, v100, fine, tGun\\WObj:=wTable;\n"
        "  ENDPROC\nENDMODULE\n"
    )
    table = tmp_path / "frames.yaml"
    table.write_text(
        f"tools:\n  tGun: {frame_yaml(kit.TOOL)}\n  wTable: {frame_yaml(np.eye(4))}\n"
        f"bases:\n  wTable: {frame_yaml(kit.USER)}\n  tGun: {frame_yaml(np.eye(4))}\n"
    )
    out = tmp_path / "out.mod"
    summary = programs.Filter("rapid", job(cal, frames_file.read(table)), src).run(out, [src])
    assert summary.n_failed == 0, summary.failures
    assert summary.corrected["pose"] == 4
    intended = _poses(src.read_text())
    sent = _poses(out.read_text())
    np.testing.assert_allclose(intended, taught, atol=0.01)
    tool = cf @ kit.TOOL
    nominal = inverse.solve(cal.nominal_mdh, cb @ kit.USER @ sent, q, tool)
    assert nominal.converged.all()
    assert np.degrees(np.abs(nominal.q - q)).max() < 2.0
    reached = kinematics.chain(cal.mdh, nominal.q) @ tool
    want = cb @ kit.USER @ intended
    miss = np.linalg.norm(reached[:, :3, 3] - want[:, :3, 3], axis=1)
    assert miss.max() < LANDS_MM, miss


def _poses(text):
    """Every robtarget's pose in the text, in order (N, 4, 4)."""
    n = r"([-\d.]+)"
    v = np.array(re.findall(rf"\[\[{n},{n},{n}\],\[{n},{n},{n},{n}\]", text), dtype=float)
    return frames.transform(rotations.quaternion_to_matrix(v[:, 3:]), v[:, :3])
