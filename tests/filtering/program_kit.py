"""Robot programs in the vendors' syntax for the filtering tests, one writer per language.

KRL's forms follow KUKA's expert programming manual, RAPID's ABB's
technical reference, URScript UR's manual, LS Fanuc's and JBI Yaskawa's
TP references; the configurations come from the filter's own solver on the
nominal arm, as a controller would have recorded them.
"""

import numpy as np
from filter_kit import BASE, TOOL, TOOL2, calibration, job, poses

from calibrator.compensate.solve import Solver
from calibrator.languages.fanuc.reader import FanucLS
from calibrator.languages.jbi.reader import JBI
from calibrator.languages.krl.reader import KRL
from calibrator.languages.rapid.reader import RAPID
from calibrator.model import frames, kinematics, rotations

CRLF = "\r\n"
#: Yaskawa pulses per degree of the JBI test arm.
PPD = [1341.4, 1341.4, 1145.8, 850.2, 850.2, 544.1]
#: The URScript programs' TCP (set_tcp), mm.
TCP = frames.transform(rotations.rotvec_to_matrix([0.0, 0.3, 0.0]), [0.0, 15.0, 160.0])


def _p(pose):
    """A (4, 4) pose as URScript's p[x, y, z, rx, ry, rz] (m, rotation vector)."""
    rv = rotations.matrix_to_rotvec(pose[:3, :3])
    x, y, z = pose[:3, 3] / 1000.0
    return f"p[{x:.6f}, {y:.6f}, {z:.6f}, {rv[0]:.5f}, {rv[1]:.5f}, {rv[2]:.5f}]"


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


def write_jbi_job(path, cal, q):
    lang = JBI.__new__(JBI)
    codes = Solver(lang, job(cal)).code_of(q)
    poses = np.linalg.inv(BASE) @ kinematics.tool_poses(cal.nominal_mdh, q, TOOL)
    home = np.round(np.array([0, 10, -10, 0, 45, 0]) * PPD).astype(int)
    out = ["/JOB", "//NAME NAHT1", "//POS", f"///NPOS {len(q) + 1},0,0,0,0,0", "///TOOL 1",
           "///POSTYPE PULSE", "///PULSE", "C00000=" + ",".join(map(str, home)),
           "///USER 2", "///TOOL 1", "///POSTYPE USER", "///RECTAN"]  # fmt: skip
    last = None
    for i, (p, c) in enumerate(zip(poses, codes, strict=True)):
        rconf = ",".join(map(str, c)) + ",0,0"
        if rconf != last:
            out.append(f"///RCONF {rconf}")
            last = rconf
        rpw = rotations.matrix_to_zyx(p[None, :3, :3], np.zeros((1, 3)))[0]
        vals = [*p[:3, 3], rpw[2], rpw[1], rpw[0]]
        out.append(
            f"C{i + 1:05d}="
            + ",".join(f"{v:.3f}" if k < 3 else f"{v:.4f}" for k, v in enumerate(vals))
        )
    out += ["//INST", "///DATE 2026/11/27 12:00", "///ATTR SC,RW", "///GROUP1 RB1", "NOP",
            "MOVJ C00000 VJ=25.00"]  # fmt: skip
    out += [f"MOVL C{i + 1:05d} V=100.0" for i in range(len(q))] + ["END", ""]
    path.write_bytes("\r\n".join(out).encode("ascii"))
    return path


def write_fanuc_ls(path, cal, q):
    lang = FanucLS.__new__(FanucLS)
    codes = Solver(lang, job(cal)).code_of(q)
    poses = np.linalg.inv(BASE) @ kinematics.tool_poses(cal.nominal_mdh, q, TOOL)
    out = [
        "/PROG  SCHWEISS", "/ATTR", "OWNER\t\t= MNEDITOR;", 'COMMENT\t\t= "Naht äöü";',
        "/MN", "   1:  UFRAME_NUM=1 ;", "   2:  UTOOL_NUM=1 ;",
    ]  # fmt: skip
    for i in range(len(q) + 1):
        out.append(
            f"   {i + 3}:{'J' if i == 0 else 'L'} P[{i + 1}] "
            f"{'100%' if i == 0 else '250mm/sec'} FINE    ;"
        )
    out += ["/POS", "P[1]{", "   GP1:", "\tUF : 1, UT : 1,\t"]
    out += ["\tJ1=     0.000 deg,\tJ2=    10.000 deg,\tJ3=   -10.000 deg,",
            "\tJ4=     0.000 deg,\tJ5=    45.000 deg,\tJ6=     0.000 deg", "};"]  # fmt: skip
    for i, (pose, c) in enumerate(zip(poses, codes, strict=True)):
        wpr = rotations.matrix_to_zyx(pose[None, :3, :3], np.zeros((1, 3)))[0][::-1]
        x, y, z = pose[:3, 3]
        conf = f"'{'NF'[c[0]]} {'UD'[c[1]]} {'TB'[c[2]]}, {c[3]}, {c[4]}, {c[5]}'"
        label = f'P[{i + 2}:"Naht {i}"]' if i % 2 else f"P[{i + 2}]"
        out += [
            label + "{", "   GP1:", f"\tUF : 1, UT : 1,\t\tCONFIG : {conf},",
            f"\tX = {x:9.3f}  mm,\tY = {y:9.3f}  mm,\tZ = {z:9.3f}  mm,",
            f"\tW = {wpr[0]:9.3f} deg,\tP = {wpr[1]:9.3f} deg,\tR = {wpr[2]:9.3f} deg",
        ]  # fmt: skip
        if i == 0:
            out += ["   GP2:", "\tUF : 1, UT : 1,", "\tJ1=    90.000 deg,\tJ2=     0.000 deg"]
        out.append("};")
    out += ["/END", ""]
    path.write_bytes("\r\n".join(out).encode("utf-8"))
    return path


def write_urscript(path, cal, q):
    pose = kinematics.tool_poses(cal.nominal_mdh, q, TCP)
    lines = [
        "def prog():",
        "  # Prüfprogramm — comments stay",
        "  set_tcp(" + _p(TCP) + ")",
        "  movej([" + ", ".join(f"{v:.5f}" for v in q[0]) + "], a=1.2, v=0.25)",
        "  approach = " + _p(pose[1]),
        "  movel(approach, a=1.2, v=0.25)  # to the part",
    ]
    for i in range(2, len(q)):
        lines.append(f"  movel({_p(pose[i])}, a=1.2, v=0.25, r=0.001)")
    lines += ["  movej(approach, a=1.2, v=0.25)", "end", ""]
    path.write_bytes("\r\n".join(lines).encode("utf-8"))
    return path


def write_rapid_module(path, cal, q):
    p1 = np.linalg.inv(BASE) @ kinematics.tool_poses(cal.nominal_mdh, q[:4], TOOL)
    p2 = kinematics.tool_poses(cal.nominal_mdh, q[4:], TOOL2)
    lines = [
        "MODULE Zelle3",
        "  ! Schweißzelle 3 — Werkstück auf dem Tisch",
        f"  PERS tooldata tWeld:=[TRUE,{rapid_pose(TOOL)},[2.5,[0,0,100],[1,0,0,0],0,0,0]];",
        f"  PERS tooldata tGrip:=[TRUE,{rapid_pose(TOOL2)},[1,[0,0,50],[1,0,0,0],0,0,0]];",
        f'  TASK PERS wobjdata wTable:=[FALSE,TRUE,"",{rapid_pose(BASE)},[[0,0,0],[1,0,0,0]]];',
        "  CONST jointtarget jHome:=[[0,0,0,0,30,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];",
    ]
    for i in range(3):
        lines.append(f"  CONST robtarget p{i + 1}0:={robtarget(cal, p1[i], q[i])};")
    # A declaration over two lines.
    text = robtarget(cal, p1[3], q[3])
    cut = text.index("],[") + 2
    lines += [f"  CONST robtarget p40:={text[:cut]}", f"      {text[cut:]};"]
    lines += ["  PROC main()", "    MoveAbsJ jHome\\NoEOffs, v1000, z50, tool0;"]
    for i in range(4):
        lines.append(f"    MoveL p{i + 1}0, v200, z10, tWeld\\WObj:=wTable; ! Naht")
    for j in range(len(q) - 4):
        lines.append(f"    MoveJ {robtarget(cal, p2[j], q[4 + j])}, v500, fine, tGrip;")
    lines += ["  ENDPROC", "ENDMODULE", ""]
    path.write_bytes("\r\n".join(lines).encode("utf-8"))
    return path
