"""The program cases the filter's first tests never reached.

Targets exactly on a turn boundary (+-180 deg, a quadrant's edge, 0 deg),
Yaskawa pulse positions with non-zero zero pulses, URScript ``movec`` (its
via point and its end point), CRLF programs filtered with ``--keep-failed``,
and a correction that exceeds ``--max-correction`` by its rotation only.
"""

from __future__ import annotations

import re

import config_kit as kit
import numpy as np
import pytest
from filter_kit import calibration, job
from vendor_kit import BOXES

from calibrator import robots
from calibrator.compensate import programs
from calibrator.languages import configuration, frames_file
from calibrator.model import frames, inverse, kinematics, rotations

LANDS_MM = 0.02

#: Language, its vendor's arm, the program writer and reader, and joints (controller, deg)
#: set exactly on a boundary of the language's configuration data.
EDGES = {
    "fanuc": ("fanuc-m20ia", kit.fanuc, kit.read_fanuc, [(3, 180.0), (3, -180.0), (5, 180.0),
                                                         (5, -180.0), (0, 0.0)]),
    "jbi": ("yaskawa-gp8", kit.jbi, kit.read_jbi, [(3, 180.0), (3, -180.0), (5, 180.0),
                                                   (5, -180.0)]),
    "rapid": ("abb-irb4600-60-205", kit.rapid, kit.read_rapid, [(0, 90.0), (0, -90.0),
                                                               (3, -90.0), (5, 180.0),
                                                               (5, -180.0), (3, 0.0)]),
    "krl": ("kuka-kr6-r900", kit.krl, kit.read_krl, [(0, 0.0), (3, 0.0), (5, 0.0)]),
}  # fmt: skip


def _edge_program(tmp_path, name, cal):
    model, write, read, edges = EDGES[name]
    arm = robots.get(model)
    box = np.array(BOXES[model], float)
    base = box.mean(axis=1) + np.array([7.0, 3.0, -4.0, 11.0, 9.0, 13.0])
    q_ctrl = np.tile(base, (len(edges), 1))
    for row, (joint, deg) in enumerate(edges):
        q_ctrl[row, joint] = deg
    q = arm.convention.to_model(np.radians(q_ctrl))
    lang = {"fanuc": kit.FanucLS, "jbi": kit.JBI, "rapid": kit.RAPID, "krl": kit.KRL}[name]
    codes = kit.CODES[lang](q_ctrl, configuration.arm_bits(arm.mdh, q))
    cb, cf = arm.model_base2controller_base, arm.model_flange2controller_flange
    user = kit.USER @ kit.OBJECT if name == "rapid" else kit.USER
    taught = frames.invert(cb @ user) @ kinematics.tool_poses(cal.nominal_mdh, q, cf @ kit.TOOL)
    src, extra = write(tmp_path, taught, codes)
    options = {k: v for k, v in extra.items() if k != "frames"}
    return src, job(cal, extra.get("frames"), **options), q, codes, cb @ user, cf @ kit.TOOL, read


@pytest.mark.parametrize("name", sorted(EDGES))
def test_a_target_on_a_boundary_round_trips_in_its_stated_code(tmp_path, name):
    """Fanuc's J6 = 180 is turn 0 and -180 turn -1 (the same pose): each is solved in its own.

    An identity calibration writes the program back byte for byte: every
    target on a boundary is solved in the code it states (a joint within
    0.01 deg of a boundary counts on either side, as the printed pose reads
    back a hair off it).
    """
    cal = calibration(model=EDGES[name][0], mm=0, rad=0)
    src, the_job, q, codes, *_ = _edge_program(tmp_path, name, cal)
    out = tmp_path / f"out{src.suffix}"
    summary = programs.Filter(name, the_job, src).run(out, [src])
    assert summary.n_failed == 0, summary.failures
    assert summary.corrected["pose"] == len(q)
    assert out.read_bytes() == src.read_bytes()


@pytest.mark.parametrize("name", sorted(EDGES))
def test_a_calibrated_target_on_a_boundary_lands_or_names_the_code_it_would_leave(tmp_path, name):
    """With a real calibration each boundary target either lands in its stated code or fails
    naming the configuration change: never a target written for another turn."""
    cal = calibration(model=EDGES[name][0], seed=4, mm=0.3, rad=0.0005)
    src, the_job, q, codes, user, tool, read = _edge_program(tmp_path, name, cal)
    the_job.keep_failed = True
    out = tmp_path / f"out{src.suffix}"
    summary = programs.Filter(name, the_job, src).run(out, [src])
    assert summary.corrected["pose"] + summary.n_failed == len(q)
    for failure in summary.failures:
        assert failure["reason"].startswith("the configuration would change from "), failure
    intended = user @ read(src.read_text())
    sent = user @ read(out.read_text())
    moved = np.abs(sent - intended).max(axis=(1, 2)) > 0
    assert moved.sum() == summary.corrected["pose"]  # failed targets are left as they were
    nominal = inverse.solve(cal.nominal_mdh, sent[moved], q[moved], tool)
    assert nominal.converged.all()
    reached = kinematics.chain(cal.mdh, nominal.q) @ tool
    miss = np.linalg.norm(reached[:, :3, 3] - intended[moved][:, :3, 3], axis=1)
    assert miss.max() < LANDS_MM, miss


# -- Yaskawa pulses with non-zero zeros ---------------------------------------------------------

PPD = np.array([1341.4, 1341.4, 1145.8, 850.2, 850.2, 544.1])
ZERO = np.array([1200, -3400, 560, 0, -2100, 7777])


def _pulse_job(tmp_path, q_ctrl_deg):
    path = tmp_path / "frames.yaml"
    path.write_text(
        f"pulses_per_degree: {PPD.tolist()}\nzero_pulses: {ZERO.tolist()}\n"
        "tools: {}\nbases: {}\n"
    )
    pulses = np.round(q_ctrl_deg * PPD + ZERO).astype(int)
    out = ["/JOB", "//NAME PULSE", "//POS", f"///NPOS {len(pulses)},0,0,0,0,0", "///TOOL 0",
           "///POSTYPE PULSE", "///PULSE"]  # fmt: skip
    out += [f"C{i:05d}=" + ",".join(map(str, p)) for i, p in enumerate(pulses)]
    out += ["//INST", "///GROUP1 RB1", "NOP"]
    out += [f"MOVJ C{i:05d} VJ=25.00" for i in range(len(pulses))] + ["END", ""]
    src = tmp_path / "PULSE.JBI"
    src.write_bytes("\r\n".join(out).encode("ascii"))
    return src, frames_file.read(path), pulses


def test_pulse_positions_with_non_zero_zeros_are_read_and_written_through_them(tmp_path):
    """``deg = (pulse - zero) / pulses_per_degree``: a corrected pulse position puts the true
    arm where the nominal arm was at the taught joints, within a pulse's resolution."""
    model = "yaskawa-gp8"
    arm = robots.get(model)
    box = np.array(BOXES[model], float)
    q_ctrl = np.random.default_rng(2).uniform(box[:, 0], box[:, 1], (6, 6))
    cal0 = calibration(model=model, mm=0, rad=0)
    src, table, pulses = _pulse_job(tmp_path, q_ctrl)
    out = tmp_path / "OUT.JBI"
    kept = programs.Filter("jbi", job(cal0, table, correct_joints=True), src).run(out, [src])
    assert kept.n_failed == 0 and kept.corrected["joints"] == 6
    assert out.read_bytes() == src.read_bytes()
    cal = calibration(model=model, seed=6, mm=0.3, rad=0.0005)
    summary = programs.Filter("jbi", job(cal, table, correct_joints=True), src).run(out, [src])
    assert summary.n_failed == 0, summary.failures
    rows = re.findall(r"^C\d{5}=(.*)$", out.read_text(), re.M)
    written = np.array([r.split(",") for r in rows], dtype=float)
    assert np.abs(written - pulses).max() > 5  # corrected by more than a few pulses
    taught = arm.convention.to_model(np.radians((pulses - ZERO) / PPD))
    moved = arm.convention.to_model(np.radians((written - ZERO) / PPD))
    flange = arm.model_flange2controller_flange
    wanted = kinematics.chain(cal.nominal_mdh, taught) @ flange
    reached = kinematics.chain(cal.mdh, moved) @ flange
    assert np.linalg.norm(reached[:, :3, 3] - wanted[:, :3, 3], axis=1).max() < 0.05


# -- URScript movec --------------------------------------------------------------------------

TCP = frames.transform(rotations.rotvec_to_matrix([0.0, 0.3, 0.0]), [0.0, 15.0, 160.0])


def _p(pose):
    rv = rotations.matrix_to_rotvec(pose[:3, :3])
    x, y, z = pose[:3, 3] / 1000.0
    return f"p[{x:.6f}, {y:.6f}, {z:.6f}, {rv[0]:.6f}, {rv[1]:.6f}, {rv[2]:.6f}]"


def _read_p(text):
    v = np.array(
        [[float(x) for x in m.split(",")] for m in re.findall(r"p\[([^\]]*)\]", text)], float
    )
    return frames.transform(rotations.rotvec_to_matrix(v[:, 3:]), 1000.0 * v[:, :3])


def test_movec_corrects_its_via_point_and_its_end_point(tmp_path):
    """Both of ``movec``'s poses are targets, inline and as variables; both land."""
    cal = calibration("ur10e", seed=2, mm=0.3, rad=0.0005)
    ends = np.array([[0.2, -1.6, 1.5, -1.4, 1.3, 0.2], [0.9, -1.2, 1.1, -1.0, 1.7, 0.9]])
    q = ends[0] + np.linspace(0, 1, 7)[:, None] * (ends[1] - ends[0])
    pose = kinematics.tool_poses(cal.nominal_mdh, q, TCP)
    lines = [
        "def arc():",
        f"  set_tcp({_p(TCP)})",
        "  movej([" + ", ".join(f"{v:.6f}" for v in q[0]) + "], a=1.2, v=0.25)",
        f"  movec({_p(pose[1])}, {_p(pose[2])}, a=1.2, v=0.25, r=0, mode=0)",
        f"  via = {_p(pose[3])}",
        f"  to = {_p(pose[4])}",
        "  movec(via, to, a=1.2, v=0.25)  # the second arc",
        f"  movel({_p(pose[5])}, a=1.2, v=0.25)",
        f"  movec({_p(pose[6])}, to, a=1.2, v=0.25)",
        "end",
        "",
    ]
    src = tmp_path / "arc.script"
    src.write_bytes("\r\n".join(lines).encode())
    out = tmp_path / "out.script"
    summary = programs.Filter("urscript", job(cal), src).run(out, [src])
    assert summary.n_failed == 0, summary.failures
    # Pose literals: 2 + 2 assigned + 1 + 1 (the last movec's end is `to` again).
    assert summary.corrected["pose"] == 6
    before, after = src.read_text(), out.read_text()
    sent, intended = _read_p(after)[1:], _read_p(before)[1:]  # without the TCP
    order = [1, 2, 3, 4, 5, 6]
    assert np.abs(sent - intended).max(axis=(1, 2)).min() > 1e-5  # every pose was corrected
    nominal = inverse.solve(cal.nominal_mdh, sent, q[order], TCP)
    reached = kinematics.chain(cal.mdh, nominal.q) @ TCP
    miss = np.linalg.norm(reached[:, :3, 3] - intended[:, :3, 3], axis=1)
    assert miss.max() < LANDS_MM, miss


# -- CRLF programs with --keep-failed ----------------------------------------------------------


def test_a_crlf_krl_program_with_keep_failed_marks_failures_before_the_line_ending(tmp_path):
    cal = calibration(model="kuka-kr6-r900", seed=3, mm=0.3, rad=0.0005)
    q, codes = kit.space("kuka-kr6-r900", kit.CODES[kit.KRL])
    q, codes = q[:6], codes[:6]
    arm = robots.get("kuka-kr6-r900")
    cb, cf = arm.model_base2controller_base, arm.model_flange2controller_flange
    taught = frames.invert(cb @ kit.USER) @ kinematics.tool_poses(cal.nominal_mdh, q, cf @ kit.TOOL)
    src, extra = kit.krl(tmp_path, taught, codes)
    text = src.read_bytes().decode()
    # The fourth target under a tool nobody defines: it fails, the rest are corrected.
    lines = text.split("\r\n")
    lines.insert(6, "$TOOL = TOOL_DATA[5]")
    lines.insert(8, "$TOOL = TOOL_DATA[1]")
    src.write_bytes("\r\n".join(lines).encode())
    out = tmp_path / "out.src"
    the_job = job(cal, config_dat=extra["config_dat"], keep_failed=True)
    summary = programs.Filter("krl", the_job, src).run(out, [src])
    assert summary.n_failed == 1 and summary.corrected["pose"] == 5
    (failure,) = summary.failures
    assert failure["line"] == 8
    written = out.read_bytes().decode()
    assert written.count("\r\n") == len(lines) - 1 and "\n" not in written.replace("\r\n", "")
    marked = written.split("\r\n")[7]
    assert marked == lines[7] + " ; not corrected: " + failure["reason"]
    assert "TOOL_DATA[5]" in failure["reason"]
    changed = [a != b for a, b in zip(lines, written.split("\r\n"), strict=True)]
    assert sum(changed) == 6  # five corrected targets and the marked one


def test_a_crlf_rapid_statement_over_two_lines_is_marked_on_its_last(tmp_path):
    cal = calibration(model="abb-irb4600-60-205", seed=3, mm=0.3, rad=0.0005)
    pose = "[[1500,100,1200],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]]"
    lines = [
        "MODULE M",
        f"  CONST robtarget pA:={pose[:20]}",
        f"    {pose[20:]};",
        "  PROC main()",
        "    MoveL pA, v100, fine, tool0\\WObj:=wNowhere;",
        "  ENDPROC",
        "ENDMODULE",
        "",
    ]
    src = tmp_path / "m.mod"
    src.write_bytes("\r\n".join(lines).encode())
    out = tmp_path / "out.mod"
    summary = programs.Filter("rapid", job(cal, keep_failed=True), src).run(out, [src])
    (failure,) = summary.failures
    assert "wobjdata wnowhere is defined neither" in failure["reason"]
    written = out.read_bytes().decode().split("\r\n")
    assert written[1] == lines[1]
    assert written[2] == lines[2] + " ! not corrected: " + failure["reason"]
    assert written[3:] == lines[3:]


# -- --max-correction by rotation only --------------------------------------------------------


def test_a_correction_beyond_the_rotation_limit_alone_fails(tmp_path):
    """Joint-zero errors turn the tool by ~0.05 deg while moving it under the mm limit."""
    cal = calibration(model="kuka-kr6-r900", seed=3, mm=0.0, rad=0.001)
    q, codes = kit.space("kuka-kr6-r900", kit.CODES[kit.KRL])
    q, codes = q[:8], codes[:8]
    arm = robots.get("kuka-kr6-r900")
    cb, cf = arm.model_base2controller_base, arm.model_flange2controller_flange
    taught = frames.invert(cb @ kit.USER) @ kinematics.tool_poses(cal.nominal_mdh, q, cf @ kit.TOOL)
    src, extra = kit.krl(tmp_path, taught, codes)
    loose = programs.Filter(
        "krl", job(cal, config_dat=extra["config_dat"], max_mm=50.0, max_deg=5.0), src
    ).run(tmp_path / "a.src", [src])
    assert loose.n_failed == 0
    # Limits between the largest correction's mm and deg: only the rotation exceeds.
    max_deg = loose.max_deg * 0.5
    tight = programs.Filter(
        "krl", job(cal, config_dat=extra["config_dat"], max_mm=50.0, max_deg=max_deg), src
    ).run(tmp_path / "b.src", [src])
    assert 0 < tight.n_failed < len(q)
    assert not (tmp_path / "b.src").exists()
    for failure in tight.failures:
        sizes = re.match(r"correction ([\d.]+) mm / ([\d.]+) deg", failure["reason"])
        mm, deg = float(sizes.group(1)), float(sizes.group(2))
        assert mm < 50.0 and deg > max_deg, failure
        assert f"--max-correction 50,{max_deg:g}" in failure["reason"]
    # And the same by the translation only.
    short = programs.Filter(
        "krl",
        job(cal, config_dat=extra["config_dat"], max_mm=loose.max_mm * 0.5, max_deg=5.0),
        src,
    ).run(tmp_path / "c.src", [src])
    assert 0 < short.n_failed < len(q)
