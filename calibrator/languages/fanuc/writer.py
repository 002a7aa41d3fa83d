"""Fanuc LS (R-30iB / R-30iB Plus, compiled on the PC with MakeTP or loaded with ASCII Upload).

A ``/PROG`` with ``/ATTR``, ``/MN`` and ``/POS`` sections. Positions are
joint representations (``J1= ... deg``) in ``/POS``; each line of ``/MN``
is numbered. ``J P[i] n% FINE`` moves at a percentage of each axis's top
speed (the smallest over the axes, so no joint exceeds the cap), ``WAIT
t(sec)`` dwells and ``DO[n]=PULSE,t sec`` pulses an output. A via (moved through, not measured) is a
``J P[i:VIA]`` with no wait; its position is commented ``via before pose i`` in ``/POS``.
The program selects user frame 0 (World) and tool frame 0 (the faceplate),
``UFRAME_NUM=0`` and ``UTOOL_NUM=0``, and its positions record ``UF : 0, UT :
0``: the frames ``calibrator compensate --joint-targets correct`` corrects in.
"""

from __future__ import annotations

import numpy as np

from calibrator.errors import CalibrationError
from calibrator.languages.names import program_name
from calibrator.languages.registry import writer
from calibrator.languages.spec import PULSE_S, ProgramSpec
from calibrator.languages.statements import between_homes

#: Longest program name on an R-30iB.
MAX_NAME = 36


def _name(stem: str) -> str:
    # The pendant lists the program under its /PROG name, which MakeTP takes from the file.
    return program_name(
        stem, language="Fanuc LS", reserved=frozenset(), max_length=MAX_NAME, same_as_file=True
    ).upper()


def _position(spec: ProgramSpec, index: int, q_rad, comment: str) -> list[str]:
    axes = [f"J{i + 1}= {v} deg" for i, v in enumerate(spec.angles(q_rad, "deg"))]
    return [
        f'P[{index}:"{comment}"]{{',
        "   GP1:",
        "\tUF : 0, UT : 0,",
        "\t" + ",\t".join(axes[:3]) + ",",
        "\t" + ",\t".join(axes[3:]),
        "};",
    ]


@writer("fanuc-ls", (".ls",), "Fanuc LS for R-30iB / R-30iB Plus (MakeTP); deg", _name, "fanuc")
def write(spec: ProgramSpec) -> str:
    if spec.pulse_output is not None and spec.pulse_output < 1:
        raise CalibrationError("Fanuc DO outputs are numbered from 1, not 0")
    name = spec.name.upper()
    pct = int(spec.speed_percent(1.0, "Fanuc LS").min())
    # P[1..N] are the poses, P[N+1] home, P[N+2..] the vias in path order.
    home = len(spec.plan_rad) + 1
    vias: list[tuple[int, int, np.ndarray]] = []  # (P index, pose it leads to, joints)

    def move(kind: str, pose: int, start: np.ndarray, q: np.ndarray) -> str:
        if kind == "via":
            vias.append((home + 1 + len(vias), pose, q))
            return f"J P[{vias[-1][0]}:VIA] {pct}% FINE"
        return f"J P[{pose + 1}] {pct}% FINE"

    # The frames the positions are recorded in: World and the faceplate (UF 0, UT 0).
    body = ["UFRAME_NUM=0", "UTOOL_NUM=0", f"J P[{home}:HOME] {pct}% FINE"]
    body += between_homes(
        spec,
        move,
        pulse=lambda output: [f"DO[{output}]=PULSE,{PULSE_S:.1f}sec"],
        dwell=lambda wait: f"WAIT {wait:.2f}(sec)",
    )
    body.append(f"J P[{home}:HOME] {pct}% FINE")
    lines = [
        f"/PROG  {name}",
        "/ATTR",
        "OWNER\t\t= MNEDITOR;",
        f'COMMENT\t\t= "{len(spec.plan_rad)} poses";',
        f"LINE_COUNT\t= {len(body)};",
        "PROTECT\t\t= READ_WRITE;",
        "DEFAULT_GROUP\t= 1,*,*,*,*;",
        "/MN",
    ]
    lines += [f"{n:4d}:  {stmt} ;" for n, stmt in enumerate(body, start=1)]
    lines.append("/POS")
    for pose, q in enumerate(spec.plan_rad):
        lines += _position(spec, pose + 1, q, f"pose {pose}")
    lines += _position(spec, home, spec.home_rad, "HOME")
    for index, pose, q in vias:
        lines += _position(spec, index, q, f"via before pose {pose}")
    lines += ["/END", ""]
    return "\n".join(lines)
