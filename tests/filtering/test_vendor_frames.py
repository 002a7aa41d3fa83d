"""Programs taught in each vendor's own frames on its own arm land where they were taught.

For every shipped arm but the UR (whose frames are its DH frames), a program
is written the way its controller records targets: in ABB's ``tool0`` and
``wobj0``, KUKA's ``$NULLFRAME`` tool and ``$ROBROOT`` base, FANUC's UT 0 and
UF 0 (World, at J2's height), Yaskawa's tool 0 in the ROBOT frame; and, in
the same program, with a tool and a user frame (RAPID: a user frame and an
object frame, both moved). Each pose comes from yourdfpy's reading of the
shipped URDF (``tool0`` in ``base``, the frames ROS-Industrial names after
the controller's), not from the description. A calibration of a perturbed
true arm filters the program; a nominal controller (its model placed in those
frames) then drives the true arm to every filtered target, which must land
within 0.02 mm of the taught pose. Before, targets taught in ABB's tool0
failed with ``no nominal joint solution found in the configuration`` and a
FANUC World program was corrected 525 mm away from the arm. The Staubli has no
VAL 3 reader: its frames go through a KRL program (tool 0 and base 0 are the
controller's flange and world on any arm).
"""

import re

import numpy as np
import pytest
from filter_kit import calibration, frame_yaml, job
from program_kit import krl_frame, rapid_pose
from vendor_kit import OBJECT, TOOL, USER, joints, landed, model_frames, pendant_poses

from calibrator import robots, session, simulate
from calibrator.calibration import Calibration
from calibrator.compensate import programs
from calibrator.compensate.solve import Solver
from calibrator.identify import pipeline
from calibrator.languages import frames_file
from calibrator.languages.registry import readers
from calibrator.model import frames, rotations

#: Largest distance of a filtered target from its taught pose on the true arm, mm.
LANDS_MM = 0.02
N = 8  # targets in the box, then five special ones (flip, quadrants, turns)


def _codes(cal, lang, q_ctrl):
    arm = robots.get(cal.model)
    cls = readers()[lang].cls
    solver = Solver(cls.__new__(cls), job(cal, convention=arm.convention))
    return solver.code_of(arm.convention.to_model(q_ctrl))


def _zyx(pose):
    return rotations.matrix_to_zyx(pose[None, :3, :3], np.zeros((1, 3)))[0]


def _krl(tmp, cal, poses, codes, own):
    src = ["DEF VF()", "$TOOL = $NULLFRAME", "$BASE = $NULLFRAME"]
    for i, (p, c) in enumerate(zip(poses, codes, strict=True)):
        if i == own:
            src += ["$TOOL = TOOL_DATA[1]", "$BASE = BASE_DATA[2]"]
        src.append(f"LIN {{{krl_frame(p)},S {c[0]},T {c[1]}}}")
    (tmp / "VF.src").write_text("\r\n".join(src + ["END", ""]))
    config = tmp / "config.dat"
    config.write_text(
        f"DEFDAT $CONFIG\nTOOL_DATA[1]={{{krl_frame(TOOL)}}}\n"
        f"BASE_DATA[2]={{{krl_frame(USER)}}}\nENDDAT\n"
    )
    return tmp / "VF.src", {"config_dat": config}


def _read_krl(text):
    num = r"([-\d.]+)"
    pat = rf"X {num},Y {num},Z {num},A {num},B {num},C {num}"
    v = np.array(re.findall(pat, text), dtype=float)
    return frames.transform(rotations.zyx_to_matrix(v[:, 3:]), v[:, :3])


def _rapid(tmp, cal, poses, codes, own):
    lines = [
        "MODULE VF",
        f"  PERS tooldata tSpindle:=[TRUE,{rapid_pose(TOOL)},[4,[0,0,80],[1,0,0,0],0,0,0]];",
        f'  PERS wobjdata wPart:=[FALSE,TRUE,"",{rapid_pose(USER)},{rapid_pose(OBJECT)}];',
    ]
    for i, (p, c) in enumerate(zip(poses, codes, strict=True)):
        conf = f"[{c[0]},{c[1]},{c[2]},{c[3]}]"
        lines.append(
            f"  CONST robtarget p{i}:={rapid_pose(p)[:-1]},{conf},[9E9,9E9,9E9,9E9,9E9,9E9]];"
        )
    lines.append("  PROC main()")
    for i in range(len(poses)):
        frame = "tool0" if i < own else "tSpindle\\WObj:=wPart"
        lines.append(f"    MoveL p{i}, v100, fine, {frame};")
    (tmp / "vf.mod").write_text("\n".join(lines + ["  ENDPROC", "ENDMODULE", ""]))
    return tmp / "vf.mod", {}


def _read_rapid(text):
    num = r"([-\d.]+)"
    pat = rf"robtarget p\d+:=\[\[{num},{num},{num}\],\[{num},{num},{num},{num}\]"
    v = np.array(re.findall(pat, text), dtype=float)
    return frames.transform(rotations.quaternion_to_matrix(v[:, 3:]), v[:, :3])


def _frames_file(tmp):
    path = tmp / "frames.yaml"
    path.write_text(f"tools:\n  '1': {frame_yaml(TOOL)}\nbases:\n  '1': {frame_yaml(USER)}\n")
    return frames_file.read(path)


def _fanuc(tmp, cal, poses, codes, own):
    out = ["/PROG  VF", "/ATTR", "/MN", "   1:  UFRAME_NUM=0 ;", "   2:  UTOOL_NUM=0 ;"]
    out += [f"   {i + 3}:L P[{i + 1}] 250mm/sec FINE    ;" for i in range(len(poses))]
    out.append("/POS")
    for i, (p, c) in enumerate(zip(poses, codes, strict=True)):
        uf = 0 if i < own else 1
        a, b, w = _zyx(p)
        conf = f"'{'NF'[c[0]]} {'UD'[c[1]]} {'TB'[c[2]]}, {c[3]}, {c[4]}, {c[5]}'"
        out += [
            f"P[{i + 1}]{{", "   GP1:", f"\tUF : {uf}, UT : {uf},\t\tCONFIG : {conf},",
            f"\tX = {p[0, 3]:.3f}  mm,\tY = {p[1, 3]:.3f}  mm,\tZ = {p[2, 3]:.3f}  mm,",
            f"\tW = {w:.4f} deg,\tP = {b:.4f} deg,\tR = {a:.4f} deg", "};",
        ]  # fmt: skip
    (tmp / "vf.ls").write_text("\n".join(out + ["/END", ""]))
    return tmp / "vf.ls", {"frames": _frames_file(tmp)}


def _read_xyzwpr(text):
    num = r"\s*([-\d.]+)"
    pat = (
        rf"X ={num}\s+mm,\tY ={num}\s+mm,\tZ ={num}\s+mm,\n"
        rf"\tW ={num} deg,\tP ={num} deg,\tR ={num} deg"
    )
    v = np.array(re.findall(pat, text), dtype=float)
    return frames.transform(rotations.zyx_to_matrix(v[:, [5, 4, 3]]), v[:, :3])


def _jbi(tmp, cal, poses, codes, own):
    out = ["/JOB", "//NAME VF", "//POS", f"///NPOS {len(poses)},0,0,0,0,0"]
    out += ["///TOOL 0", "///POSTYPE ROBOT", "///RECTAN"]
    for i, (p, c) in enumerate(zip(poses, codes, strict=True)):
        if i == own:
            out += ["///USER 1", "///TOOL 1", "///POSTYPE USER"]
        a, b, w = _zyx(p)
        out.append("///RCONF " + ",".join(map(str, c)) + ",0,0")
        out.append(f"C{i:05d}={p[0, 3]:.3f},{p[1, 3]:.3f},{p[2, 3]:.3f},{w:.4f},{b:.4f},{a:.4f}")
    out += ["//INST", "///DATE 2026/12/06 10:00", "///GROUP1 RB1", "NOP"]
    out += [f"MOVL C{i:05d} V=100.0" for i in range(len(poses))] + ["END", ""]
    (tmp / "VF.JBI").write_text("\n".join(out))
    return tmp / "VF.JBI", {"frames": _frames_file(tmp)}


def _read_jbi(text):
    rows = re.findall(r"^C\d{5}=(.*)$", text, re.M)
    v = np.array([r.split(",") for r in rows], dtype=float)
    return frames.transform(rotations.zyx_to_matrix(v[:, [5, 4, 3]]), v[:, :3])


#: Arm, its language, the program writer and reader, and the frames of the second half.
CASES = {
    "kuka-kr6-r900": ("krl", _krl, _read_krl, USER),
    "abb-irb4600-60-205": ("rapid", _rapid, _read_rapid, USER @ OBJECT),
    "fanuc-m20ia": ("fanuc", _fanuc, _read_xyzwpr, USER),
    "yaskawa-gp8": ("jbi", _jbi, _read_jbi, USER),
    "staubli-tx2-60": ("krl", _krl, _read_krl, USER),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_a_program_in_the_vendors_frames_lands_on_the_taught_pose(tmp_path, name):
    lang, write, read, user = CASES[name]
    base2frame0, flange2tool0 = model_frames(name)
    q = joints(name, N, seed=7)
    n = len(q)
    own = n // 2  # the first half in the controller's own frames, the rest in USER/TOOL
    users = np.array([np.eye(4)] * own + [user] * (n - own))
    tools = np.array([np.eye(4)] * own + [TOOL] * (n - own))
    taught = frames.invert(users) @ pendant_poses(name, q) @ tools
    cal = calibration(model=name, seed=5, mm=1.0, rad=0.001)
    codes = _codes(cal, lang, q)
    src, extra = write(tmp_path, cal, taught, codes, own)
    out = tmp_path / f"out{src.suffix}"
    config_dat = extra.get("config_dat")
    filtered = programs.Filter(lang, job(cal, extra.get("frames"), config_dat=config_dat), src).run(
        out, [src]
    )
    assert filtered.n_failed == 0, filtered.failures
    assert filtered.corrected["pose"] == n
    intended = users @ read(src.read_text())
    sent = read(out.read_text())
    assert len(sent) == n
    reached = landed(cal, base2frame0, flange2tool0, sent, users, tools, q)
    miss = np.linalg.norm(reached[:, :3, 3] - intended[:, :3, 3], axis=1)
    turn = np.linalg.norm(rotations.rotation_error(reached[:, :3, :3], intended[:, :3, :3]), axis=1)
    assert miss.max() < LANDS_MM, miss
    assert turn.max() < 2e-5, turn
    # Unfiltered, the same controller puts the true arm a calibration's error away.
    raw = landed(cal, base2frame0, flange2tool0, read(src.read_text()), users, tools, q)
    assert np.linalg.norm(raw[:, :3, 3] - intended[:, :3, 3], axis=1).min() > 10 * LANDS_MM
    # The flipped wrist and the two turns of joint 6 each state a configuration of their own.
    assert tuple(codes[-5]) != tuple(codes[0]) and tuple(codes[-2]) != tuple(codes[-1])


def test_an_identified_fanuc_corrects_a_world_program_where_the_arm_works(tmp_path):
    """The FANUC case end to end: a simulated M-20iA with hidden errors is identified
    from its session, and an LS program taught in UF 0 (World, 525 mm up at J2) and
    UT 0 is filtered with that calibration; the true arm, driven by the nominal
    controller, lands on the taught positions. The old filter read UF 0 as the model's
    base, 525 mm below World: it wrote every target (exit 0) and the arm landed 5.6 to
    6.2 mm off, the corrections computed 525 mm from where the arm works."""
    table, meta, truth = simulate.simulate(
        model="fanuc-m20ia", poses=60, seed=11, frame="base", errors="random",
        noise_mm=0.001, orientation_noise_rad=1e-6,
    )  # fmt: skip
    path = tmp_path / "s.parquet"
    session.write(path, table, meta)
    result = pipeline.identify(session.load(path), pipeline.Options(method="lm"))
    cal = Calibration.from_result(result, path, "fanuc-m20ia", "base")
    base2frame0, flange2tool0 = model_frames("fanuc-m20ia")
    q = joints("fanuc-m20ia", 6, seed=2)[:6]
    eye = np.array([np.eye(4)] * len(q))
    src, _ = _fanuc(tmp_path, cal, pendant_poses("fanuc-m20ia", q), _codes(cal, "fanuc", q), 99)
    out = tmp_path / "out.ls"
    # The simulated arm's errors are several times a real arm's: corrections of tens of mm.
    filtered = programs.Filter("fanuc", job(cal, max_mm=80.0, max_deg=5.0), src).run(out, [src])
    assert filtered.n_failed == 0, filtered.failures
    intended = _read_xyzwpr(src.read_text())
    truth_cal = Calibration(nominal_mdh=cal.nominal_mdh, mdh=truth.mdh, model="fanuc-m20ia")
    reached = landed(truth_cal, base2frame0, flange2tool0, _read_xyzwpr(out.read_text()),
                     eye, eye, q)  # fmt: skip
    raw = landed(truth_cal, base2frame0, flange2tool0, intended, eye, eye, q)
    miss = np.linalg.norm(reached[:, :3, 3] - intended[:, :3, 3], axis=1)
    assert miss.max() < LANDS_MM, miss
    assert np.linalg.norm(raw[:, :3, 3] - intended[:, :3, 3], axis=1).min() > 1.0
