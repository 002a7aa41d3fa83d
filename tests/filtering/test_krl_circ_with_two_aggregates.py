"""KRL ``CIRC`` with its auxiliary and end points written inline: two aggregates on one line.

Each aggregate is its own target, also in the general form (an ``E6POS``
with external axes after ``S`` and ``T``, which the fast pattern does not
take): both land on the true arm. An end point cut off at the line's end
fails alone; the auxiliary point before it is still corrected.
"""

from __future__ import annotations

import re

import config_kit as kit
import numpy as np
from filter_kit import calibration, job
from program_kit import krl_frame

from calibrator import robots
from calibrator.compensate import programs
from calibrator.model import frames, inverse, kinematics

MODEL = "kuka-kr6-r900"


def _program(tmp_path, cut=False):
    arm = robots.get(MODEL)
    q, codes = kit.space(MODEL, kit.CODES[kit.KRL])
    q, codes = q[:4], codes[:4]
    cal = calibration(MODEL, seed=12, mm=0.3, rad=0.0005)
    cb, cf = arm.model_base2controller_base, arm.model_flange2controller_flange
    taught = frames.invert(cb @ kit.USER) @ kinematics.chain(cal.nominal_mdh, q) @ cf @ kit.TOOL
    agg = [
        f"{{{krl_frame(p)},S {c[0]},T {c[1]},E1 0.0,E2 0.0}}"
        for p, c in zip(taught, codes, strict=True)
    ]
    second = agg[3][: agg[3].index(",")] if cut else agg[3]  # "{X 123.456": cut off
    src = tmp_path / "ARC.src"
    src.write_text(
        "DEF ARC()\n$TOOL = TOOL_DATA[1]\n$BASE = BASE_DATA[2]\n"
        f"CIRC {agg[0]},{agg[1]} CA 90.0 C_DIS\nCIRC {agg[2]}, {second}\nEND\n"
    )
    config = tmp_path / "config.dat"
    config.write_text(
        f"DEFDAT $CONFIG\nTOOL_DATA[1]={{{krl_frame(kit.TOOL)}}}\n"
        f"BASE_DATA[2]={{{krl_frame(kit.USER)}}}\nENDDAT\n"
    )
    return src, config, cal, q, arm


def test_both_inline_points_of_circ_land(tmp_path):
    src, config, cal, q, arm = _program(tmp_path)
    out = tmp_path / "out" / "ARC.src"
    out.parent.mkdir()
    summary = programs.Filter("krl", job(cal, config_dat=config), src).run(out, [src])
    assert summary.n_failed == 0, summary.failures
    assert summary.corrected["pose"] == 4
    intended, sent = kit.read_krl(src.read_text()), kit.read_krl(out.read_text())
    assert re.findall(r",E1 0.0,E2 0.0\}", out.read_text()) == [",E1 0.0,E2 0.0}"] * 4
    cb, cf = arm.model_base2controller_base, arm.model_flange2controller_flange
    tool = cf @ kit.TOOL
    nominal = inverse.solve(cal.nominal_mdh, cb @ kit.USER @ sent, q, tool)
    assert nominal.converged.all()
    reached = kinematics.chain(cal.mdh, nominal.q) @ tool
    want = cb @ kit.USER @ intended
    assert np.linalg.norm(reached[:, :3, 3] - want[:, :3, 3], axis=1).max() < 0.02


def test_a_cut_off_end_point_fails_alone(tmp_path):
    src, config, cal, q, arm = _program(tmp_path, cut=True)
    the_job = job(cal, config_dat=config, keep_failed=True)
    summary = programs.Filter("krl", the_job, src).run(tmp_path / "out.src", [src])
    assert summary.corrected["pose"] == 3
    assert [(f["line"], f["reason"]) for f in summary.failures] == [
        (5, "a partial aggregate cannot be corrected")
    ]
