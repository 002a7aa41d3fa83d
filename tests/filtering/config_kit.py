"""Programs in every language, targets from model joints, and the vendors' configuration codes.

The codes are written out from the vendors' definitions (KUKA's S and T,
ABB's confdata, Fanuc's CONFIG, Yaskawa's RCONF), independently of the
filter's encoders, for the configuration-space and program-edge tests.
"""

from __future__ import annotations

import re

import numpy as np
from filter_kit import frame_yaml
from program_kit import krl_frame, rapid_pose

from calibrator import robots
from calibrator.languages import configuration, frames_file
from calibrator.languages.fanuc.reader import FanucLS
from calibrator.languages.jbi.reader import JBI
from calibrator.languages.krl.reader import KRL
from calibrator.languages.rapid.reader import RAPID
from calibrator.model import frames, rotations, singularities

TOOL = frames.transform(rotations.zyx_to_matrix([[10.0, 25.0, -5.0]])[0], [12.5, -4.0, 180.0])
USER = frames.transform(rotations.zyx_to_matrix([[30.0, 5.0, -3.0]])[0], [300.0, -200.0, 150.0])
#: RAPID's object frame in the user frame: both move, so uframe @ oframe != oframe @ uframe.
OBJECT = frames.transform(rotations.zyx_to_matrix([[-15.0, 0.0, 12.0]])[0], [50.0, 100.0, 20.0])


# -- the vendors' definitions, written out here ---------------------------------------------


def krl_code(q_deg, bits):
    """KUKA: S bit 0 overhead (back), bit 1 elbow up, bit 2 A5 negative; T bit i: A(i+1) < 0."""
    back, down, flip = bits.T
    s = back * 1 + (1 - down) * 2 + flip * 4
    t = sum((q_deg[:, i] < 0).astype(int) * 2**i for i in range(6))
    return np.column_stack([s, t])


def rapid_code(q_deg, bits):
    """ABB: cf1, cf4, cf6 the quadrants; cfx 4 back + 2 down + flip."""
    quad = np.floor_divide(q_deg[:, [0, 3, 5]], 90.0).astype(int)
    back, down, flip = bits.T
    return np.column_stack([quad, 4 * back + 2 * down + flip])


def fanuc_turn(q_deg):
    """Fanuc's turn number: ``t`` with ``q - 360 t`` in (-180, 180]."""
    return -np.floor_divide(180.0 - np.asarray(q_deg, float), 360.0).astype(int)


def fanuc_code(q_deg, bits):
    back, down, flip = bits.T
    return np.column_stack([flip, down, back, fanuc_turn(q_deg[:, [0, 3, 5]])])


def jbi_code(q_deg, bits):
    """Yaskawa: flip, lower arm, back; R (axis 4), T (axis 6), S (axis 1) beyond a half turn."""
    back, down, flip = bits.T
    q = q_deg[:, [3, 5, 0]]
    beyond = ~((q >= -180.0) & (q < 180.0))
    return np.column_stack([flip, down, back, beyond.astype(int)])


CODES = {KRL: krl_code, RAPID: rapid_code, FanucLS: fanuc_code, JBI: jbi_code}


def bare(cls):
    return cls.__new__(cls)  # the encoders need no program


def space(model, code_of, seed=1, n=20000):
    """Model joints (rad), one row per code ``code_of`` gives, clear of singularities; the codes.

    Codes are of the controller's angles (the arm's convention: KUKA's
    reversed A1 and A6, FANUC's J2/J3 coupling). Also clear of every code's
    boundaries (joints 1 deg from a multiple of 90) and of the limits, so a
    calibration's small correction keeps the code.
    """
    arm = robots.get(model)
    lim = arm.joint_limits_rad
    q = np.random.default_rng(seed).uniform(lim[:, 0] * 0.97, lim[:, 1] * 0.97, (n, 6))
    q = q[~arm.outside_limits(q).any(axis=1)]
    m = singularities.margins(arm.mdh, q)
    deg = np.degrees(arm.convention.to_controller(q))
    off = np.abs((deg + 45.0) % 90.0 - 45.0)
    keep = (m[:, 0] > 25) & (m[:, 1] > 25) & (m[:, 2] > 250) & (off > 1.0).all(axis=1)
    q, deg = q[keep], deg[keep]
    codes = code_of(deg, configuration.arm_bits(arm.mdh, q))
    if codes.shape[1] == 4:  # RAPID's thousands: every cfx with every quadrant of each joint
        keys = [codes[:, [0, 3]], codes[:, [1, 3]], codes[:, [2, 3]]]
    else:
        keys = [codes]
    first = np.unique(np.concatenate([np.unique(k, axis=0, return_index=True)[1] for k in keys]))
    return q[first], codes[first]


def zyx(pose):
    return rotations.matrix_to_zyx(pose[None, :3, :3], np.zeros((1, 3)))[0]


def read_zyx(text, pat, order):
    v = np.array(re.findall(pat, text), dtype=float)
    return frames.transform(rotations.zyx_to_matrix(v[:, order]), v[:, :3])


def frames_table(tmp):
    path = tmp / "frames.yaml"
    # Different numbers for the tool and the user frame: a reader that swaps them fails.
    path.write_text(f"tools:\n  '3': {frame_yaml(TOOL)}\nbases:\n  '2': {frame_yaml(USER)}\n")
    return frames_file.read(path)


def krl(tmp, poses, codes):
    src = ["DEF SPACE()", "$TOOL = TOOL_DATA[1]", "BAS(#BASE, 2)"]
    src += [
        f"LIN {{{krl_frame(p)},S {c[0]},T {c[1]}}} C_DIS" for p, c in zip(poses, codes, strict=True)
    ]
    (tmp / "SPACE.src").write_bytes(("\r\n".join([*src, "END", ""])).encode())
    config = tmp / "config.dat"
    config.write_text(
        f"DEFDAT $CONFIG\nTOOL_DATA[1]={{{krl_frame(TOOL)}}}\nBASE_DATA[2]={{{krl_frame(USER)}}}\n"
        "ENDDAT\n"
    )
    return tmp / "SPACE.src", {"config_dat": config}


def read_krl(text):
    n = r"([-\d.]+)"
    return read_zyx(text, rf"X {n},Y {n},Z {n},A {n},B {n},C {n}", [3, 4, 5])


def rapid(tmp, poses, codes):
    lines = [
        "MODULE Space",
        f"  PERS tooldata tSpindle:=[TRUE,{rapid_pose(TOOL)},[4,[0,0,80],[1,0,0,0],0,0,0]];",
        f'  PERS wobjdata wPart:=[FALSE,TRUE,"",{rapid_pose(USER)},{rapid_pose(OBJECT)}];',
        "  PROC main()",
    ]
    for p, c in zip(poses, codes, strict=True):
        conf = f"[{c[0]},{c[1]},{c[2]},{c[3]}]"
        lines.append(
            f"    MoveL {rapid_pose(p)[:-1]},{conf},[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, "
            "tSpindle\\WObj:=wPart;"
        )
    (tmp / "space.mod").write_text("\n".join([*lines, "  ENDPROC", "ENDMODULE", ""]))
    return tmp / "space.mod", {}


def read_rapid(text):
    n = r"([-\d.]+)"
    v = np.array(re.findall(rf"MoveL \[\[{n},{n},{n}\],\[{n},{n},{n},{n}\]", text), dtype=float)
    return frames.transform(rotations.quaternion_to_matrix(v[:, 3:]), v[:, :3])


def fanuc(tmp, poses, codes):
    out = ["/PROG  SPACE", "/MN", "/POS"]
    for i, (p, c) in enumerate(zip(poses, codes, strict=True)):
        a, b, w = zyx(p)
        conf = f"'{'NF'[c[0]]} {'UD'[c[1]]} {'TB'[c[2]]}, {c[3]}, {c[4]}, {c[5]}'"
        out += [
            f"P[{i + 1}]{{", "   GP1:", f"\tUF : 2, UT : 3,\t\tCONFIG : {conf},",
            f"\tX = {p[0, 3]:.3f}  mm,\tY = {p[1, 3]:.3f}  mm,\tZ = {p[2, 3]:.3f}  mm,",
            f"\tW = {w:.4f} deg,\tP = {b:.4f} deg,\tR = {a:.4f} deg", "};",
        ]  # fmt: skip
    (tmp / "space.ls").write_text("\n".join([*out, "/END", ""]))
    return tmp / "space.ls", {"frames": frames_table(tmp)}


def read_fanuc(text):
    n = r"\s*([-\d.]+)"
    pat = rf"X ={n}\s+mm,\tY ={n}\s+mm,\tZ ={n}\s+mm,\n\tW ={n} deg,\tP ={n} deg,\tR ={n} deg"
    return read_zyx(text, pat, [5, 4, 3])


def jbi(tmp, poses, codes):
    out = ["/JOB", "//NAME SPACE", "//POS", f"///NPOS {len(poses)},0,0,0,0,0"]
    out += ["///USER 2", "///TOOL 3", "///POSTYPE USER", "///RECTAN"]
    for i, (p, c) in enumerate(zip(poses, codes, strict=True)):
        a, b, w = zyx(p)
        out.append("///RCONF " + ",".join(map(str, c)) + ",0,0")
        out.append(f"C{i:05d}={p[0, 3]:.3f},{p[1, 3]:.3f},{p[2, 3]:.3f},{w:.4f},{b:.4f},{a:.4f}")
    out += ["//INST", "///GROUP1 RB1", "NOP"]
    out += [f"MOVL C{i:05d} V=100.0" for i in range(len(poses))] + ["END", ""]
    (tmp / "SPACE.JBI").write_text("\n".join(out))
    return tmp / "SPACE.JBI", {"frames": frames_table(tmp)}


def read_jbi(text):
    rows = re.findall(r"^C\d{5}=(.*)$", text, re.M)
    v = np.array([r.split(",") for r in rows], dtype=float)
    return frames.transform(rotations.zyx_to_matrix(v[:, [5, 4, 3]]), v[:, :3])


#: Language, its vendor's arm, the frame its targets are written in, the program's writer
