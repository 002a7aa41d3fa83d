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
from calibrator.languages import configuration
from calibrator.languages.names import program_name
from calibrator.languages.path_program import PathSpec
from calibrator.languages.registry import writer
from calibrator.languages.spec import PULSE_S, ProgramSpec
from calibrator.languages.statements import between_homes
from calibrator.model import rotations

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


#: Termination of a blended move (a circle's two arcs meet tangentially): no stop, no rounding
#: of a tangential junction.
BLEND = "CNT100"


def _config(spec: PathSpec, k: int) -> str:
    """``'N U T, t1, t4, t6'``: flip, elbow, arm, turn numbers of J1, J4, J6 (controller's)."""
    convention = spec.joints.convention
    q = spec.q_rad[k]
    ctrl = np.degrees(convention.to_controller(q) if convention is not None else q)
    back, down, flip = configuration.arm_bits(spec.mdh, q[None])[0]
    t1, t4, t6 = (int(configuration.turn(ctrl[j])) for j in (0, 3, 5))
    return f"'{'NF'[flip]} {'UD'[down]} {'TB'[back]}, {t1}, {t4}, {t6}'"


def _cartesian(spec: PathSpec, index: int, k: int, comment: str) -> list[str]:
    x, y, z = (f"{round(float(v), 3) + 0.0:.3f}" for v in spec.position(k))
    # W, P, R: about the fixed X, Y, Z axes, Rz(R) Ry(P) Rx(W), deg.
    r, p, w = rotations.matrix_to_zyx(spec.rotation(k)[None], np.zeros(3))[0]
    w, p, r = (f"{round(float(v), 3) + 0.0:.3f}" for v in (w, p, r))
    return [
        f'P[{index}:"{comment}"]{{',
        "   GP1:",
        f"\tUF : 0, UT : 0,\t\tCONFIG : {_config(spec, k)},",
        f"\tX = {x} mm,\tY = {y} mm,\tZ = {z} mm,",
        f"\tW = {w} deg,\tP = {p} deg,\tR = {r} deg",
        "};",
    ]


def write_path(spec: PathSpec) -> str:
    """The path program in Fanuc LS: ``J`` to the start, ``L`` and ``C`` at mm/sec.

    Positions are the faceplate (``UT : 0``) in the world frame (``UF : 0``):
    ``P[1]`` the start in joints, ``P[2..]`` the path's targets as Cartesian
    positions (mm, W P R in deg) with their configuration. A circular move
    is ``C P[via]`` with its end ``P[end]`` on the continuation line; path
    speeds are whole mm/sec (the written speed is the stated one rounded
    down, never faster); ``FINE`` stops exactly, ``CNT100`` blends.

    Raises
    ------
    CalibrationError
        A speed below 1 mm/sec.
    """
    joints = spec.joints
    name = spec.name.upper()
    pct = int(joints.speed_percent(1.0, "Fanuc LS").min())
    speed = int(np.floor(spec.speed_mm_s + 1e-9))
    if speed < 1:
        raise CalibrationError("Fanuc LS states path speeds in whole mm/sec: at least 1")
    # P[1] the start (joints), P[2 + k] target k (P[2] the start again, as a position).
    body: list[str] = ["UFRAME_NUM=0", "UTOOL_NUM=0", f"J P[1:START] {pct}% FINE"]
    for _step, move in spec.steps():
        if move is None:
            body.append(f"WAIT {spec.hold_s:.2f}(sec)")
            continue
        term = BLEND if move.blend else "FINE"
        if move.kind == "line":
            body.append(f"L P[{move.end + 2}] {speed}mm/sec {term}")
        else:
            assert move.via is not None
            body.append(f"C P[{move.via + 2}] \n    :  P[{move.end + 2}] {speed}mm/sec {term}")
    lines = [
        f"/PROG  {name}",
        "/ATTR",
        "OWNER\t\t= MNEDITOR;",
        f'COMMENT\t\t= "ISO 9283 {spec.shape} path";',
        f"LINE_COUNT\t= {len(body)};",
        "PROTECT\t\t= READ_WRITE;",
        "DEFAULT_GROUP\t= 1,*,*,*,*;",
        "/MN",
    ]
    lines += [f"{n:4d}:  {stmt} ;" for n, stmt in enumerate(body, start=1)]
    lines.append("/POS")
    lines += _position(joints, 1, joints.home_rad, "START")
    for k in range(len(spec.poses)):
        lines += _cartesian(spec, k + 2, k, f"path {k}")
    lines += ["/END", ""]
    return "\n".join(lines)
