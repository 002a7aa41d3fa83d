"""The summary printed after a filter run lists at most 20 failures, then how many more."""

from __future__ import annotations

import pytest
from filter_kit import calibration, job

from calibrator.compensate import programs


@pytest.mark.parametrize("n", [20, 21, 23])
def test_the_summary_names_twenty_failures_and_counts_the_rest(tmp_path, n):
    src = tmp_path / "MANY.src"
    moves = "".join(f"LIN {{X {500 + i},Y 0,Z 800,A 0,B 90,C 0,S 2,T 0}}\n" for i in range(n))
    src.write_text(f"DEF MANY()\n$TOOL = TOOL_DATA[9]\n$BASE = $NULLFRAME\n{moves}END\n")
    the_job = job(calibration("kuka-kr6-r900"), keep_failed=True)
    summary = programs.Filter("krl", the_job, src).run(tmp_path / "out.src", [src])
    assert summary.n_failed == n
    lines = summary.lines()
    named = [line for line in lines if ": LIN: TOOL_DATA[9] is defined neither" in line]
    assert len(named) == 20
    assert named[0].startswith(f"{src}:4: ") and named[-1].startswith(f"{src}:23: ")
    more = [line for line in lines if line.startswith("... and ")]
    assert more == ([] if n == 20 else [f"... and {n - 20} more (see --summary)"])
