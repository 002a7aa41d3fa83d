"""Tools and bases changed between targets land each target in the frames active at its move.

A KRL program changes its base and tool by every form KUKA's manual gives
(``$BASE = BASE_DATA[n]``, ``BAS(#BASE, n)``, ``BAS(#TOOL, n)``,
``$TOOL = $NULLFRAME``, ``$BASE = $NULLFRAME`` and ``FDAT_ACT = FPn`` with an
``FDAT`` that names both numbers or only its tool), with inline targets in the
``.src`` and declared ones in the ``.dat``; a Yaskawa job changes ``///USER``,
``///TOOL`` and ``///POSTYPE`` between its positions. Every frame is a
different transform, so a target read in the frame before or after its own
lands centimetres away: each must land on the simulated true arm within
0.02 mm.
"""

from __future__ import annotations

import re

import config_kit as kit
import numpy as np
import pytest
from filter_kit import calibration, frame_yaml, job
from program_kit import krl_frame

from calibrator import robots
from calibrator.compensate import programs
from calibrator.languages import configuration, frames_file
from calibrator.languages.reading import FilterError
from calibrator.model import frames, inverse, kinematics, rotations

LANDS_MM = 0.02
TOOL2 = frames.transform(rotations.zyx_to_matrix([[-40.0, 15.0, 5.0]])[0], [-20.0, 35.0, 140.0])
BASE3 = frames.transform(rotations.zyx_to_matrix([[-70.0, 3.0, 8.0]])[0], [-150.0, 420.0, -60.0])
TOOLS = {0: np.eye(4), 1: kit.TOOL, 2: TOOL2}
BASES = {0: np.eye(4), 2: kit.USER, 3: BASE3}


def _lands(cal, arm, q, intended, sent, tools):
    """Largest distance (mm) of the true arm from ``intended`` when sent ``sent``.

    ``intended`` and ``sent`` are (N, 4, 4) in the controller's base; ``tools``
    (N, 4, 4) on the controller's flange.
    """
    cb, cf = arm.model_base2controller_base, arm.model_flange2controller_flange
    tool = cf @ tools
    nominal = inverse.solve(cal.nominal_mdh, cb @ sent, q, tool)
    assert nominal.converged.all()
    assert np.degrees(np.abs(nominal.q - q)).max() < 2.0  # the same configuration
    reached = kinematics.chain(cal.mdh, nominal.q) @ tool
    want = cb @ intended
    turn = rotations.rotation_error(reached[:, :3, :3], want[:, :3, :3])
    assert np.linalg.norm(turn, axis=1).max() < 2e-5
    return np.linalg.norm(reached[:, :3, 3] - want[:, :3, 3], axis=1).max()


# -- KRL ----------------------------------------------------------------------------------------

#: Before each target: the lines that set its frames, and its (tool, base) numbers then.
#: Odd targets are declared in the .dat (``LIN XPn``), even ones written inline.
KRL_STEPS = [
    (["$TOOL = TOOL_DATA[1]", "$BASE = BASE_DATA[2]"], (1, 2)),
    (["BAS(#BASE, 3)"], (1, 3)),
    (["BAS(#TOOL, 2)"], (2, 3)),
    (["FDAT_ACT = FP1"], (1, 0)),  # FP1: TOOL_NO 1, BASE_NO 0
    (["$BASE = BASE_DATA[2]"], (1, 2)),
    (["FDAT_ACT = FPTOOL"], (2, 2)),  # FPTOOL names its tool only: the base stays
    (["$TOOL = $NULLFRAME"], (0, 2)),
    (["$BASE = $NULLFRAME", "$TOOL = TOOL_DATA[2]"], (2, 0)),
    (["BAS(#BASE, 3) ; and a comment", "$TOOL = TOOL_DATA[1]"], (1, 3)),
    ([], (1, 3)),  # nothing changes
]


def _krl_program(tmp_path, cal, arm, q, codes):
    cb, cf = arm.model_base2controller_base, arm.model_flange2controller_flange
    src = ["DEF MOVES()"]
    dat = [
        "DEFDAT MOVES",
        "DECL FDAT FP1={TOOL_NO 1,BASE_NO 0,IPO_FRAME #BASE}",
        "DECL FDAT FPTOOL={TOOL_NO 2,IPO_FRAME #BASE}",
    ]
    taught = []
    for i, ((lines, (t, b)), qi, c) in enumerate(zip(KRL_STEPS, q, codes, strict=True)):
        pose = frames.invert(cb @ BASES[b]) @ kinematics.chain(cal.nominal_mdh, qi[None])[0]
        pose = pose @ cf @ TOOLS[t]
        taught.append(pose)
        src += lines
        value = f"{{{krl_frame(pose)},S {c[0]},T {c[1]}}}"
        if i % 2:
            dat.append(f"DECL E6POS XP{i}={value[:-1]},E1 0.0,E2 0.0}}")
            src.append(f"LIN XP{i} C_DIS")
        else:
            src.append(f"LIN {value} C_DIS ; t{i}")
    (tmp_path / "MOVES.src").write_bytes("\r\n".join([*src, "END", ""]).encode())
    (tmp_path / "MOVES.dat").write_bytes("\r\n".join([*dat, "ENDDAT", ""]).encode())
    config = tmp_path / "config.dat"
    config.write_text(
        "DEFDAT $CONFIG\n"
        + "".join(f"TOOL_DATA[{n}]={{{krl_frame(TOOLS[n])}}}\n" for n in (1, 2))
        + "".join(f"BASE_DATA[{n}]={{{krl_frame(BASES[n])}}}\n" for n in (2, 3))
        + "ENDDAT\n"
    )
    return tmp_path / "MOVES.src", config, np.array(taught)


def _krl_targets(src_text, dat_text):
    """The poses (N, 4, 4) of the program's targets in the order of KRL_STEPS."""
    out = {}
    for m in re.finditer(r"LIN (\{[^}]*\}) C_DIS ; t(\d+)", src_text):
        out[int(m.group(2))] = kit.read_krl(m.group(1))[0]
    for m in re.finditer(r"XP(\d+)=(\{[^}]*\})", dat_text):
        out[int(m.group(1))] = kit.read_krl(m.group(2))[0]
    return np.array([out[i] for i in range(len(KRL_STEPS))])


def test_krl_targets_land_in_the_tool_and_base_active_at_each_move(tmp_path):
    model = "kuka-kr6-r900"
    arm = robots.get(model)
    q, codes = kit.space(model, kit.CODES[kit.KRL])
    q, codes = q[: len(KRL_STEPS)], codes[: len(KRL_STEPS)]
    cal = calibration(model=model, seed=8, mm=0.3, rad=0.0005)
    src, config, taught = _krl_program(tmp_path, cal, arm, q, codes)
    out = tmp_path / "out" / "MOVES.src"
    out.parent.mkdir()
    summary = programs.Filter("krl", job(cal, config_dat=config), src).run(out, [src])
    assert summary.n_failed == 0, summary.failures
    assert summary.corrected["pose"] == len(KRL_STEPS)
    before = _krl_targets(src.read_text(), src.with_suffix(".dat").read_text())
    after = _krl_targets(out.read_text(), out.with_suffix(".dat").read_text())
    np.testing.assert_allclose(before, taught, atol=1e-3)
    used = [KRL_STEPS[i][1] for i in range(len(KRL_STEPS))]
    bases = np.array([BASES[b] for _, b in used])
    tools = np.array([TOOLS[t] for t, _ in used])
    miss = _lands(cal, arm, q, bases @ before, bases @ after, tools)
    assert miss < LANDS_MM, miss


def test_a_declared_target_moved_to_again_after_a_base_change_is_refused(tmp_path):
    """One value cannot be corrected for two bases: both lines are named."""
    cal = calibration(model="kuka-kr6-r900", mm=0, rad=0)
    (tmp_path / "TWICE.dat").write_text(
        "DEFDAT TWICE\nDECL E6POS XP1={X 500,Y 0,Z 600,A 0,B 90,C 0,S 2,T 0}\nENDDAT\n"
    )
    src = tmp_path / "TWICE.src"
    src.write_text(
        "DEF TWICE()\n$TOOL = $NULLFRAME\nBAS(#BASE, 2)\nLIN XP1\nBAS(#BASE, 3)\nLIN XP1\nEND\n"
    )
    with pytest.raises(FilterError) as refused:
        programs.Filter("krl", job(cal), src)
    message = str(refused.value)
    assert message.startswith(f"{src}:6: XP1 is moved to with tool 0 and base 3 here")
    assert "tool 0 and base 2 on line 4" in message


# -- Yaskawa JBI --------------------------------------------------------------------------------

JBI_TOOLS = {0: np.eye(4), 1: kit.TOOL, 3: TOOL2}
JBI_USERS = {1: BASE3, 2: kit.USER}
#: Before each position: its header lines, and its (tool, user or None for the robot base).
JBI_STEPS = [
    (["///TOOL 1", "///USER 2", "///POSTYPE USER", "///RECTAN"], (1, 2)),
    ([], (1, 2)),
    (["///USER 1"], (1, 1)),
    (["///TOOL 3"], (3, 1)),
    (["///POSTYPE ROBOT"], (3, None)),
    (["///TOOL 0", "///POSTYPE BASE"], (0, None)),
    (["///POSTYPE USER", "///USER 2"], (0, 2)),
    (["///TOOL 1"], (1, 2)),
]


def test_jbi_positions_land_in_the_user_frame_and_tool_of_their_headers(tmp_path):
    model = "yaskawa-gp8"
    arm = robots.get(model)
    q, codes = kit.space(model, kit.CODES[kit.JBI])
    n = len(JBI_STEPS)
    q, codes = q[:n], codes[:n]
    cal = calibration(model=model, seed=9, mm=0.3, rad=0.0005)
    cb, cf = arm.model_base2controller_base, arm.model_flange2controller_flange
    tools = np.array([JBI_TOOLS[t] for _, (t, _) in JBI_STEPS])
    bases = np.array([np.eye(4) if u is None else JBI_USERS[u] for _, (_, u) in JBI_STEPS])
    taught = frames.invert(cb @ bases) @ kinematics.chain(cal.nominal_mdh, q) @ cf @ tools
    out = ["/JOB", "//NAME MOVES", "//POS", f"///NPOS {n},0,0,0,0,0"]
    for i, ((lines, _), p, c) in enumerate(zip(JBI_STEPS, taught, codes, strict=True)):
        a, b, w = kit.zyx(p)
        # Eight flags as DX controllers write them; the third with the six that are read.
        out += [*lines, "///RCONF " + ",".join(map(str, c)) + ("" if i == 2 else ",0,0")]
        out.append(f"C{i:05d}={p[0, 3]:.3f},{p[1, 3]:.3f},{p[2, 3]:.3f},{w:.4f},{b:.4f},{a:.4f}")
    out += ["//INST", "///GROUP1 RB1", "NOP"]
    out += [f"MOVL C{i:05d} V=100.0" for i in range(n)] + ["END", ""]
    src = tmp_path / "MOVES.JBI"
    src.write_bytes("\r\n".join(out).encode("ascii"))
    table = tmp_path / "frames.yaml"
    table.write_text(
        "tools:\n"
        + "".join(f"  '{k}': {frame_yaml(v)}\n" for k, v in JBI_TOOLS.items() if k)
        + "bases:\n"
        + "".join(f"  '{k}': {frame_yaml(v)}\n" for k, v in JBI_USERS.items())
    )
    the_job = job(cal, frames_file.read(table))
    result = tmp_path / "OUT.JBI"
    summary = programs.Filter("jbi", the_job, src).run(result, [src])
    assert summary.n_failed == 0, summary.failures
    assert summary.corrected["pose"] == n
    before, after = kit.read_jbi(src.read_text()), kit.read_jbi(result.read_text())
    np.testing.assert_allclose(before, taught, atol=1e-3)
    assert _lands(cal, arm, q, bases @ before, bases @ after, tools) < LANDS_MM
    # The configuration each position states is the one the corrected joints have.
    nominal = inverse.solve(cal.nominal_mdh, cb @ bases @ after, q, cf @ tools)
    ctrl = np.degrees(arm.convention.to_controller(nominal.q))
    bits = configuration.arm_bits(cal.nominal_mdh, nominal.q)
    np.testing.assert_array_equal(kit.CODES[kit.JBI](ctrl, bits), codes)
