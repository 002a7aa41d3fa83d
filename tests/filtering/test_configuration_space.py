"""Every language's configuration space: each code it can state is read, solved and written back.

A program states which of a pose's joint solutions it means: KUKA's ``S``
and ``T``, ABB's ``[cf1, cf4, cf6, cfx]``, Fanuc's ``'N U T, t1, t4, t6'``,
Yaskawa's ``RCONF``. The codes here are computed from the vendors'
definitions, independently of the filter's own encoders, so a slipped bit,
sign or boundary in the filter's reading of them shows as a target it cannot
solve or one it solves in another configuration than the program states.

Three layers: the encoders against the definitions (hypothesis, over the
whole space and at its boundaries), the geometric bits against the eight
solutions of one pose, and programs with one target for every code an arm
can reach, in frames that move (a tool and a user frame; RAPID's user and
object frame both), filtered with a calibration and driven by a nominal
controller onto the true arm.
"""

from __future__ import annotations

import config_kit as kit
import numpy as np
import pytest
from filter_kit import calibration, job
from hypothesis import given, settings
from hypothesis import strategies as st

from calibrator import robots
from calibrator.compensate import programs
from calibrator.languages import configuration
from calibrator.languages.fanuc.reader import FanucLS
from calibrator.languages.jbi.reader import JBI
from calibrator.languages.krl.reader import KRL
from calibrator.languages.rapid.reader import RAPID
from calibrator.languages.urscript.reader import URScript
from calibrator.model import frames, inverse, kinematics, rotations

#: Hypothesis runs: few examples, no deadline, the same examples every run.
SETTINGS = settings(max_examples=80, deadline=None, derandomize=True)
#: Largest distance of a filtered target from its intended pose on the true arm, mm.
LANDS_MM = 0.02

# -- 1. the encoders against the definitions -------------------------------------------------

_angles = st.lists(
    st.floats(-539.0, 539.0, allow_nan=False).map(lambda v: round(v, 3)), min_size=6, max_size=6
)
_bits = st.lists(st.integers(0, 1), min_size=3, max_size=3)
#: Angles on the boundaries of every language's turn and quadrant data.
_edges = st.lists(
    st.sampled_from([-540.0, -360.0, -270.0, -180.0, -90.0, 0.0, 90.0, 180.0, 270.0, 360.0, 540.0]),
    min_size=6,
    max_size=6,
)


@pytest.mark.parametrize("cls", list(kit.CODES), ids=lambda c: c.name)
@SETTINGS
@given(q=st.one_of(_angles, _edges), bits=_bits)
def test_each_languages_code_is_its_vendors_definition_and_reads_back(cls, q, bits):
    lang = kit.bare(cls)
    q_deg, b = np.array([q]), np.array([bits])
    code = lang.code(q_deg, b)
    np.testing.assert_array_equal(code, kit.CODES[cls](q_deg, b))
    # Reading a stated code gives the geometric bits the program meant.
    np.testing.assert_array_equal(lang.code_bits(kit.CODES[cls](q_deg, b)), b)


@SETTINGS
@given(bits=_bits)
def test_urscript_states_the_bits_themselves(bits):
    b = np.array([bits])
    lang = kit.bare(URScript)
    np.testing.assert_array_equal(lang.code_bits(lang.code(np.zeros((1, 6)), b)), b)
    words = configuration.describe_bits(b[0]).split(", ")
    assert words == [
        ("front", "back")[bits[0]],
        ("up", "down")[bits[1]],
        ("noflip", "flip")[bits[2]],
    ]


@pytest.mark.parametrize(
    ("deg", "turn", "quadrant", "negative", "beyond"),
    [
        (-540.0, -2, -6, 1, 1), (-539.99, -1, -6, 1, 1), (-180.0, -1, -2, 1, 0),
        (-179.99, 0, -2, 1, 0), (-90.0, 0, -1, 1, 0), (-0.01, 0, -1, 1, 0), (0.0, 0, 0, 0, 0),
        (89.99, 0, 0, 0, 0), (90.0, 0, 1, 0, 0), (179.99, 0, 1, 0, 0), (180.0, 0, 2, 0, 1),
        (180.01, 1, 2, 0, 1), (359.99, 1, 3, 0, 1), (540.0, 1, 6, 0, 1), (540.01, 2, 6, 0, 1),
    ],
)  # fmt: skip
def test_the_boundaries_of_turns_and_quadrants(deg, turn, quadrant, negative, beyond):
    """Fanuc's 0 is (-180, 180], ABB's quadrant 0 is [0, 90), Yaskawa's flag is set at +180."""
    assert configuration.turn([deg])[0] == turn
    assert configuration.quadrant([deg])[0] == quadrant
    assert configuration.negative([deg])[0] == negative
    assert configuration.beyond_half_turn([deg])[0] == beyond


def test_krl_reads_status_and_turn_in_binary_and_decimal(tmp_path):
    """``S 'B110'`` is 6 and ``T 'B100011'`` 35, as KUKA's editors write them."""
    cal = calibration(mm=0, rad=0)
    src = tmp_path / "p.src"
    src.write_text(
        "DEF P()\n$TOOL = $NULLFRAME\n$BASE = $NULLFRAME\n"
        "LIN {X 900,Y 0,Z 800,A 0,B 90,C 0,S 'B110',T 'B100011'}\n"
        "LIN {X 900,Y 0,Z 800,A 0,B 90,C 0,S 6,T 35}\nEND\n"
    )
    lang = KRL(job(cal), src)
    targets = [t for u in lang.scan(src) for t in u.targets]
    assert [t.code for t in targets] == [(6, 35), (6, 35)]
    assert lang.describe(targets[0].code) == "S 6 T 35"


def test_fanuc_reads_every_flag_and_signed_turn_numbers(tmp_path):
    cal = calibration(mm=0, rad=0)
    blocks = []
    want = []
    for i, (f, d, b, t1, t4, t6) in enumerate(
        [("F", "D", "B", -1, 1, 0), ("N", "U", "T", 1, -1, -1), ("N", "D", "T", 0, 0, 1)]
    ):
        conf = f"{t1}, {t4}, {t6}"
        blocks += [
            f"P[{i + 1}]{{", "   GP1:", f"\tUF : 0, UT : 0,\tCONFIG : '{f} {d} {b}, {conf}',",
            "\tX = 900.000  mm,\tY = 0.000  mm,\tZ = 800.000  mm,",
            "\tW = 180.000 deg,\tP = 0.000 deg,\tR = 0.000 deg", "};",
        ]  # fmt: skip
        want.append((int(f == "F"), int(d == "D"), int(b == "B"), t1, t4, t6))
    src = tmp_path / "p.ls"
    src.write_text("\n".join(["/PROG P", "/MN", "/POS", *blocks, "/END", ""]))
    lang = FanucLS(job(cal), src)
    codes = [t.code for u in lang.scan(src) for t in u.targets]
    assert codes == want
    assert lang.describe(codes[0]) == "'F D B, -1, 1, 0'"
    np.testing.assert_array_equal(lang.code_bits(np.array(want)), [[1, 1, 1], [0, 0, 0], [0, 1, 0]])


def test_rapid_reads_negative_quadrants_and_every_cfx(tmp_path):
    cal = calibration(mm=0, rad=0)
    lines = ["MODULE M"]
    want = []
    for cfx in range(8):
        cf = (-2 + cfx % 4, 1 - cfx % 3, -1 - cfx % 2)
        want.append((*cf, cfx))
        lines.append(
            f"  CONST robtarget p{cfx}:=[[900,0,800],[0,0,1,0],[{cf[0]},{cf[1]},{cf[2]},{cfx}],"
            "[9E9,9E9,9E9,9E9,9E9,9E9]];"
        )
    lines += ["  PROC main()", *[f"    MoveL p{i}, v100, fine, tool0;" for i in range(8)]]
    src = tmp_path / "m.mod"
    src.write_text("\n".join([*lines, "  ENDPROC", "ENDMODULE", ""]))
    lang = RAPID(job(cal), src)
    codes = [t.code for u in lang.scan(src) for t in u.targets]
    assert codes == want
    bits = lang.code_bits(np.array(want))
    np.testing.assert_array_equal(bits, [[c >> 2 & 1, c >> 1 & 1, c & 1] for c in range(8)])


# -- 2. the geometric bits --------------------------------------------------------------------


@pytest.mark.parametrize("model", ["er10l-c10", "ur10e"])
def test_the_eight_solutions_of_a_pose_carry_the_eight_bit_combinations(model):
    """A pose away from singularities has eight joint solutions, one per configuration.

    They are found from starts spread over the joint space: every combination
    of shoulder, elbow and wrist bits is among them. On the ER10L-C10 the
    usual working pose (wrist in front, forearm above the lower arm, joint 5
    positive) is front, up, noflip.
    """
    arm = robots.get(model)
    if model == "ur10e":
        q0 = np.array([[0.3, -1.6, 1.4, -1.2, 1.1, 0.4]])
    else:
        q0 = np.array([[0.3, 0.2, -0.3, 0.4, 0.9, 0.2]])
        assert configuration.arm_bits(arm.mdh, q0).tolist() == [[0, 0, 0]]
    b0 = configuration.arm_bits(arm.mdh, q0)[0]
    pose = kinematics.chain(arm.mdh, q0)
    rng = np.random.default_rng(0)
    starts = rng.uniform(-np.pi, np.pi, (3000, 6))
    sol = inverse.solve(arm.mdh, np.repeat(pose, len(starts), 0), starts, np.eye(4))
    q = sol.q[sol.converged]
    bits = configuration.arm_bits(arm.mdh, q)
    assert {tuple(b) for b in bits.tolist()} == {
        (s, e, w) for s in (0, 1) for e in (0, 1) for w in (0, 1)
    }
    if model == "ur10e":
        return  # no spherical wrist: its other wrist solution is not the one below
    # The wrist's other solution (q4 + pi, -q5, q6 + pi) differs in the flip bit only.
    other = q0 + np.array([[0, 0, 0, np.pi, -2 * q0[0, 4], np.pi]])
    np.testing.assert_allclose(kinematics.chain(arm.mdh, other), pose, atol=1e-9)
    assert configuration.arm_bits(arm.mdh, other).tolist() == [[b0[0], b0[1], 1 - b0[2]]]


# -- 3. programs with one target for every code ----------------------------------------------


#: and reader, and the values each column of its code takes on that arm (every one the
#: arm's limits allow: KUKA's 8 S and 64 T; ABB's quadrants of joints 1, 4, 6 with every
#: cfx; FANUC's turn numbers -1, 0, 1 of J4 and J6; Yaskawa's R and T flags both ways).
SPACES = {
    "krl": (KRL, "kuka-kr6-r900", kit.USER, kit.krl, kit.read_krl, [range(8), range(64)]),
    "rapid": (RAPID, "abb-irb4600-60-205", kit.USER @ kit.OBJECT, kit.rapid, kit.read_rapid,
              [range(-2, 2), range(-5, 5), range(-5, 5), range(8)]),
    "fanuc": (FanucLS, "fanuc-m20ia", kit.USER, kit.fanuc, kit.read_fanuc,
              [(0, 1), (0, 1), (0, 1), (0,), (-1, 0, 1), (-1, 0, 1)]),
    "jbi": (JBI, "yaskawa-gp8", kit.USER, kit.jbi, kit.read_jbi, [(0, 1)] * 5 + [(0,)]),
}  # fmt: skip


@pytest.mark.parametrize("name", sorted(SPACES))
def test_a_target_in_every_configuration_lands_on_the_true_arm(tmp_path, name):
    """Every code, in a tool and a moved user frame (RAPID: user and object frame), lands.

    The program is in the controller's frames and angles (its base and
    flange, the arm's convention); the calibration is of a perturbed arm; a
    nominal controller solves each filtered target in the stated
    configuration (from the joints it was taught at) and the true arm turns
    to those joints.
    """
    cls, model, user, write, read, values = SPACES[name]
    q, codes = kit.space(model, kit.CODES[cls])
    for col, want in enumerate(values):
        assert set(codes[:, col].tolist()) == set(want), col
    arm = robots.get(model)
    cb, cf = arm.model_base2controller_base, arm.model_flange2controller_flange
    tool = cf @ kit.TOOL  # on the model's flange
    cal = calibration(model=model, seed=5, mm=0.3, rad=0.0005)
    taught = frames.invert(cb @ user) @ kinematics.tool_poses(cal.nominal_mdh, q, tool)
    src, extra = write(tmp_path, taught, codes)
    out = tmp_path / f"out{src.suffix}"
    options = {k: v for k, v in extra.items() if k != "frames"}
    summary = programs.Filter(name, job(cal, extra.get("frames"), **options), src).run(out, [src])
    assert summary.n_failed == 0, summary.failures[:5]
    assert summary.corrected["pose"] == len(q)
    intended = cb @ user @ read(src.read_text())
    sent = cb @ user @ read(out.read_text())
    nominal = inverse.solve(cal.nominal_mdh, sent, q, tool)
    assert nominal.converged.all()
    assert np.degrees(np.abs(nominal.q - q)).max() < 2.0
    ctrl = np.degrees(arm.convention.to_controller(nominal.q))
    bits = configuration.arm_bits(cal.nominal_mdh, nominal.q)
    np.testing.assert_array_equal(kit.CODES[cls](ctrl, bits), codes)
    reached = kinematics.chain(cal.mdh, nominal.q) @ tool
    miss = np.linalg.norm(reached[:, :3, 3] - intended[:, :3, 3], axis=1)
    turn = np.linalg.norm(rotations.rotation_error(reached[:, :3, :3], intended[:, :3, :3]), axis=1)
    assert miss.max() < LANDS_MM, (miss.max(), int(miss.argmax()))
    assert turn.max() < 2e-5
    # Unfiltered, the same controller misses by the calibration's error.
    raw = kinematics.chain(cal.mdh, inverse.solve(cal.nominal_mdh, intended, q, tool).q)
    assert np.median(np.linalg.norm((raw @ tool)[:, :3, 3] - intended[:, :3, 3], axis=1)) > 0.2


def test_bits_read_the_same_points_as_the_singularity_model():
    from calibrator.languages.configuration import _points
    from calibrator.model import singularities

    rng = np.random.default_rng(7)
    for name in ("ur10e", "er10l-c10"):
        mdh = robots.get(name).mdh
        q = rng.uniform(-np.pi, np.pi, (500, 6))
        reference = singularities.points(mdh, q)[:5]
        for ours, theirs in zip(_points(mdh, q), reference, strict=True):
            assert np.array_equal(ours, theirs)  # the same numbers, bit for bit
