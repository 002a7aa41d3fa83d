"""Positions cut short: a Fanuc block left open at the end of the file, RAPID robtargets short
of numbers. Each fails alone, naming why; the positions before it are corrected."""

from __future__ import annotations

import numpy as np
import pytest
from filter_kit import calibration, job

from calibrator.compensate import programs

FANUC_BLOCK = [
    "   GP1:",
    "\tUF : 0, UT : 0,\t\tCONFIG : 'N U T, 0, 0, 0',",
    "\tX = 900.000  mm,\tY = 100.000  mm,\tZ = 800.000  mm,",
    "\tW = 170.000 deg,\tP = 5.000 deg,\tR = 10.000 deg",
]


@pytest.mark.parametrize("ending", ["", "\n/END\n"], ids=["end-of-file", "before-end"])
def test_a_fanuc_position_left_open_fails_naming_its_missing_close(tmp_path, ending):
    text = "\n".join(["/PROG P", "/MN", "/POS", "P[1]{", *FANUC_BLOCK, "};", "P[2]{", *FANUC_BLOCK])
    src = tmp_path / "p.ls"
    src.write_text(text + ending)
    cal = calibration("fanuc-m20ia", mm=0.3, rad=0.0005)
    the_job = job(cal, keep_failed=True)
    summary = programs.Filter("fanuc", the_job, src).run(tmp_path / "out.ls", [src])
    assert summary.corrected["pose"] == 1
    (failure,) = summary.failures
    assert failure["target"] == "P[2]" and failure["line"] == 13
    assert failure["reason"] == "P[2] is not closed by '};'"


@pytest.mark.parametrize(
    ("conf", "problem"),
    [
        ("[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]", None),  # the usual robtarget
        ("[0,0,0,0]", None),  # no external axes: the arm's part is whole
        ("[0,0,0]", "an incomplete target"),  # a confdata value short
    ],
)
def test_a_robtarget_needs_its_pose_and_all_four_confdata_values(tmp_path, conf, problem):
    src = tmp_path / "m.mod"
    src.write_text(
        "MODULE M\n"
        f"  CONST robtarget p1:=[[1500,100,1200],[0,0,1,0],{conf}];\n"
        "  PROC main()\n    MoveL p1, v100, fine, tool0;\n  ENDPROC\nENDMODULE\n"
    )
    cal = calibration("abb-irb4600-60-205", mm=0.3, rad=0.0005)
    summary = programs.Filter("rapid", job(cal, keep_failed=True), src).run(
        tmp_path / "out.mod", [src]
    )
    reasons = [f["reason"] for f in summary.failures]
    if problem is None:
        assert reasons == [] and summary.corrected["pose"] == 1
        assert np.isfinite(summary.max_mm) and summary.max_mm > 0
    else:
        assert reasons == [problem]
