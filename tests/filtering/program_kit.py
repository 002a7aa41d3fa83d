"""Robot programs in the vendors' syntax for the filtering tests: KRL and RAPID targets.

KRL's forms follow KUKA's expert programming manual, RAPID's ABB's
technical reference; the configurations come from the filter's own solver
on the nominal arm, as a controller would have recorded them.
"""

import numpy as np
from filter_kit import BASE, TOOL, TOOL2, calibration, job, poses

from calibrator.filtering import rotations
from calibrator.filtering.krl import KRL
from calibrator.filtering.rapid import RAPID
from calibrator.filtering.solve import Solver

CRLF = "\r\n"


def krl_frame(pose):
    """A FRAME's components (X to C: mm and deg) of a (4, 4) pose."""
    abc = rotations.matrix_to_zyx(pose[None, :3, :3], np.zeros((1, 3)))[0]
    x, y, z = pose[:3, 3]
    return f"X {x:.3f},Y {y:.3f},Z {z:.3f},A {abc[0]:.4f},B {abc[1]:.4f},C {abc[2]:.4f}"


def krl_status_turn(q):
    """KRL's S and T of joint angles ``q`` (rad) on the nominal arm."""
    lang = KRL.__new__(KRL)
    cal = calibration(mm=0, rad=0)
    s, t = Solver(lang, job(cal)).code_of(q[None])[0]
    return f"S {s},T {t}"


def write_krl_program(tmp_path, cal, q, name="weld"):
    """A .src/.dat pair: declared points in base 2 with tool 1, inline points with tool 2."""
    n = len(q)
    half = n // 2
    p1 = poses(cal, q[:half], TOOL, BASE)
    p2 = poses(cal, q[half:], TOOL2, np.eye(4))
    dat = [
        f"&ACCESS RVP{CRLF}",
        f"DEFDAT {name.upper()}{CRLF}",
        f";FOLD EXTERNAL DECLARATIONS; Schweißnaht äöü{CRLF}",
    ]
    src = [
        f"&ACCESS RVP{CRLF}",
        f"DEF {name.upper()}(){CRLF}",
        f"; Naht 1 — Grundplatte{CRLF}",
        f"DECL E6AXIS HOMEPOS{CRLF}",
        f"HOMEPOS = {{A1 0.0,A2 -10.0,A3 10.0,A4 0.0,A5 45.0,A6 0.0}}{CRLF}",
        f"$TOOL = TOOL_DATA[1]{CRLF}",
        f"BAS(#BASE, 2){CRLF}",
        f"PTP {{A1 0.0,A2 0.0,A3 0.0,A4 0.0,A5 45.0,A6 0.0}}{CRLF}",
    ]
    dat.append(f'DECL FDAT FP1={{TOOL_NO 1,BASE_NO 2,IPO_FRAME #BASE,POINT2[] " "}}{CRLF}')
    for i in range(half):
        dat.append(
            f"DECL E6POS XP{i + 1}={{{krl_frame(p1[i])},{krl_status_turn(q[i])},"
            f"E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}}{CRLF}"
        )
        src.append(f"{'PTP' if i % 2 else 'LIN'} XP{i + 1} C_DIS ; point {i + 1}{CRLF}")
    src.append(f"$TOOL = TOOL_DATA[2]{CRLF}")
    src.append(f"$BASE = BASE_DATA[0]{CRLF}")
    for j in range(n - half):
        src.append(
            f"  LIN {{{krl_frame(p2[j])},{krl_status_turn(q[half + j])}}} C_VEL  ; inline{CRLF}"
        )
    src += [f"PTP HOMEPOS{CRLF}", f"END{CRLF}"]
    dat.append(f"ENDDAT{CRLF}")
    (tmp_path / f"{name}.src").write_bytes("".join(src).encode("cp1252"))
    (tmp_path / f"{name}.dat").write_bytes("".join(dat).encode("cp1252"))
    config = tmp_path / "config.dat"
    lines = []
    for n_, t in ((1, TOOL), (2, TOOL2)):
        lines.append(f"TOOL_DATA[{n_}]={{{krl_frame(t)}}}\n")
    lines.append(f"BASE_DATA[2]={{{krl_frame(BASE)}}}\n")
    config.write_text("DEFDAT $CONFIG\n" + "".join(lines) + "ENDDAT\n")
    return tmp_path / f"{name}.src", config


def rapid_quaternion(rot):
    """A (3, 3) rotation as RAPID's quaternion [q1, q2, q3, q4], q1 the scalar."""
    return rotations.matrix_to_quaternion(rot[None], [[1, 0, 0, 0]])[0]


def rapid_pose(t):
    """A (4, 4) pose as RAPID's pose: [[x, y, z], [q1, q2, q3, q4]], mm."""
    q = rapid_quaternion(t[:3, :3])
    return (
        f"[[{t[0, 3]:.2f},{t[1, 3]:.2f},{t[2, 3]:.2f}],"
        f"[{q[0]:.6f},{q[1]:.6f},{q[2]:.6f},{q[3]:.6f}]]"
    )


def robtarget(cal, pose, q):
    """A robtarget of ``pose`` with the configuration of joint angles ``q`` (rad)."""
    lang = RAPID.__new__(RAPID)
    cf = Solver(lang, job(cal)).code_of(q[None])[0]
    return (
        rapid_pose(pose)[:-1]
        + f",[{cf[0]},{cf[1]},{cf[2]},{cf[3]}],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]]"
    )
