"""CSV: the program as a table, for controllers that import point lists or a hand-written program.

Columns ``step,kind,pose,q1_deg..q6_deg,q1_rad..q6_rad,speed_rad_s,dwell_s``:
a ``home`` row, one ``pose`` row per plan pose in order (``pose`` is its
plan row), each after its ``via`` rows (moved through, dwell 0; ``pose`` is the
pose they lead to), and a ``home`` row at the end.
"""

from __future__ import annotations

import csv
import io

import numpy as np

from calibrator.program import ProgramSpec, degrees, writer
from calibrator.program.spec import DEG_DECIMALS, RAD_DECIMALS

COLUMNS = (
    "step",
    "kind",
    "pose",
    *(f"q{i}_deg" for i in range(1, 7)),
    *(f"q{i}_rad" for i in range(1, 7)),
    "speed_rad_s",
    "dwell_s",
)


@writer("csv", (".csv",), "CSV table of the moves (any controller); deg and rad")
def write(spec: ProgramSpec) -> str:
    buf = io.StringIO()
    out = csv.writer(buf, lineterminator="\n")
    out.writerow(COLUMNS)
    for step, (kind, pose, _, q) in enumerate(spec.moves()):
        deg = [f"{v:.{DEG_DECIMALS}f}" for v in degrees(q)]
        rad = [f"{v:.{RAD_DECIMALS}f}" for v in np.asarray(q, float)]
        dwell = f"{spec.dwell_s:.3f}" if kind == "pose" else "0"
        out.writerow(
            [step, kind, "" if pose is None else pose, *deg, *rad, spec.speed_rad_s, dwell]
        )
    return buf.getvalue()
