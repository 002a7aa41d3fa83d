"""CSV: the program as a table, for controllers that import point lists or a hand-written program.

Columns ``step,kind,pose,q1_deg..q6_deg,q1_rad..q6_rad,speed_rad_s,dwell_s``:
a ``home`` row, one ``pose`` row per plan pose in order (``pose`` is its
plan row), each after its ``via`` rows (moved through, dwell 0; ``pose`` is the
pose they lead to), and a ``home`` row at the end.
"""

from __future__ import annotations

import csv
import io

from calibrator.languages.registry import writer
from calibrator.languages.spec import ProgramSpec

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
        deg = spec.angles(q, "deg")
        rad = spec.angles(q, "rad")
        dwell = f"{spec.dwell_s:.3f}" if kind == "pose" else "0"
        out.writerow(
            [step, kind, "" if pose is None else pose, *deg, *rad, spec.speed_rad_s, dwell]
        )
    return buf.getvalue()
