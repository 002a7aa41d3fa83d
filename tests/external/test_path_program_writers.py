"""``program --path``: each language's path program lands on verify's commanded path.

Read back here with the test's own patterns (not the writers' code), each
target (the flange in the controller's base frame, in the language's units
and angles) is taken through the arm's controller frames to the reflector in
the model's base frame: it must lie on the line, circle or rectangle
``verify --path`` commands with the same options, the circle's via points
half-way along their arcs; the joint move to the start, read through the
controller's joint convention, must put the reflector at the path's start;
the stated path speed is the asked one in the language's unit.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from cli_kit import cli, one_line_error
from path_kit import TOOL, commanded, reflector

from calibrator import robots
from calibrator.model import frames, kinematics, rotations

NUM = r"[-+]?\d+(?:\.\d+)?"

ARMS = [
    ("ur10e", "p.script", "urscript"),
    ("kuka-kr6-r900", "p.src", "krl"),
    ("abb-irb4600-60-205", "p.mod", "rapid"),
    ("fanuc-m20ia", "p.ls", "fanuc-ls"),
]


def _floats(text: str) -> list[float]:
    return [float(v) for v in re.findall(NUM, text)]


def targets(fmt: str, text: str) -> np.ndarray:
    """Every Cartesian target in program order (a circle's via before its end), (K, 4, 4), mm."""
    if fmt == "krl":
        rows = [_floats(m) for m in re.findall(r"\{(X [^}]*)\}", text)]
        return frames.transform(
            rotations.zyx_to_matrix([r[3:6] for r in rows]), [r[:3] for r in rows]
        )
    if fmt == "rapid":
        rows = [
            _floats(a) + _floats(b) for a, b in re.findall(r"\[\[([^\]]*)\],\[([^\]]*)\],", text)
        ]
        rows = [r for r in rows if len(r) == 7]
        return frames.transform(
            rotations.quaternion_to_matrix([r[3:] for r in rows]), [r[:3] for r in rows]
        )
    if fmt == "urscript":
        code = "\n".join(line.split("#")[0] for line in text.splitlines())
        rows = [_floats(m) for m in re.findall(r"p\[([^\]]*)\]", code)][1:]  # after set_tcp's
        rot = np.array([rotations.rotvec_to_matrix(r[3:]) for r in rows])
        return frames.transform(rot, [np.multiply(r[:3], 1000.0) for r in rows])
    # Fanuc: the /MN lines name P[n]; /POS holds them (P[1] the start, in joints).
    pos = {}
    for n, body in re.findall(r"P\[(\d+):\"[^\"]*\"\]\{(.*?)\};", text, re.S):
        if "X =" in body:
            v = {k: float(x) for k, x in re.findall(rf"\b([XYZWPR]) = ({NUM})", body)}
            rot = rotations.zyx_to_matrix([[v["R"], v["P"], v["W"]]])[0]
            pos[int(n)] = frames.transform(rot, [v["X"], v["Y"], v["Z"]])
    main = text.split("/MN")[1].split("/POS")[0]
    order = [int(n) for n in re.findall(r"\bP\[(\d+)\]", main)]
    return np.array([pos[n] for n in order])


def start_joints(fmt: str, text: str) -> np.ndarray:
    """The joint move's target, the controller's angles (6,), rad."""
    if fmt == "krl":
        line = re.search(r"START_POS = \{(.*)\}", text).group(1)
        return np.radians(_floats(re.sub(r"A\d", "", line)))
    if fmt == "rapid":
        return np.radians(_floats(re.search(r"jStart := \[\[([^\]]*)\]", text).group(1)))
    if fmt == "urscript":
        return np.array(_floats(re.search(r"start = \[([^\]]*)\]", text).group(1)))
    block = re.search(r"P\[1:\"START\"\]\{(.*?)\};", text, re.S).group(1)
    return np.radians([float(v) for v in re.findall(rf"J\d= ({NUM}) deg", block)])


@pytest.fixture(scope="module", params=ARMS, ids=[a[2] for a in ARMS])
def circle(request, tmp_path_factory):
    name, output, fmt = request.param
    folder = tmp_path_factory.mktemp(fmt)
    done = cli(
        "program", "--path", "circle", "--model", name, "-o", output, "--path-speed", "150",
        "--cycles", "2", "--dwell", "1.5", cwd=folder,
    )  # fmt: skip
    assert done.code == 0, done.stderr
    return robots.get(name), fmt, (folder / output).read_text()


def test_every_target_lies_on_the_commanded_circle_via_points_half_way(circle):
    arm, fmt, text = circle
    path, rotation = commanded(arm, "circle")
    got = targets(fmt, text)
    # Per cycle two arcs: (via at a quarter, end at half), (via at three quarters, end at start).
    assert len(got) == 2 * 2 * 2
    s = np.array([0.25, 0.5, 0.75, 1.0] * 2) * path.length_mm
    np.testing.assert_allclose(reflector(arm, got), path.point(s), rtol=0, atol=2e-3)
    # The tool keeps verify's orientation at every target.
    model_rot = (
        arm.model_base2controller_base[:3, :3]
        @ got[:, :3, :3]
        @ arm.model_flange2controller_flange[:3, :3].T
    )
    np.testing.assert_allclose(model_rot, np.broadcast_to(rotation, model_rot.shape), atol=1e-6)


def test_the_joint_move_puts_the_reflector_at_the_paths_start_in_controller_angles(circle):
    arm, fmt, text = circle
    path, _ = commanded(arm, "circle")
    q_model = arm.convention.to_model(start_joints(fmt, text)[None])
    at = kinematics.forward(arm.mdh, q_model, frames.transform(translation=TOOL))[0, :3, 3]
    np.testing.assert_allclose(at, path.point(np.array([0.0]))[0], rtol=0, atol=2e-3)


def test_the_stated_speed_is_the_asked_one_in_the_languages_unit(circle):
    _, fmt, text = circle
    speeds = {
        "krl": re.findall(r"\$VEL\.CP = (" + NUM + ")", text),
        "rapid": re.findall(r"speeddata vPath := \[(" + NUM + "),", text),
        "urscript": re.findall(r"movec\(.*\bv=(" + NUM + ")", text),
        "fanuc-ls": re.findall(r"(\d+)mm/sec", text),
    }[fmt]
    scale = {"krl": 1000.0, "urscript": 1000.0}.get(fmt, 1.0)
    assert speeds and {float(v) * scale for v in speeds} == {150.0}


def test_holds_at_the_start_and_after_each_cycle_and_blends_only_between_the_arcs(circle):
    _, fmt, text = circle
    wait = {
        "krl": r"WAIT SEC 1\.500",
        "rapid": r"WaitTime \\InPos, 1\.500",
        "urscript": r"sleep\(1\.500\)",
        "fanuc-ls": r"WAIT 1\.50\(sec\)",
    }[fmt]
    assert len(re.findall(wait, text)) == 1 + 2
    blended = {
        "krl": r"C_DIS",
        "rapid": r"z1, tool0",
        "urscript": r"r=0\.001",
        "fanuc-ls": r"CNT100",
    }[fmt]
    assert len(re.findall(blended, text)) == 2  # the first arc of each cycle


@pytest.mark.parametrize("shape", ["line", "rectangle"])
def test_the_line_and_the_rectangle_stop_exactly_at_their_vertices(tmp_path, shape):
    arm = robots.get("kuka-kr6-r900")
    done = cli(
        "program",
        "--path",
        shape,
        "--model",
        arm.name,
        "-o",
        "p.src",
        "--cycles",
        "2",
        cwd=tmp_path,
    )
    assert done.code == 0, done.stderr
    text = (tmp_path / "p.src").read_text()
    assert not re.search(r"C_DIS|^CIRC", text, re.M)
    path, _ = commanded(arm, shape)
    got = reflector(arm, targets("krl", text))
    if shape == "line":
        # There and back per cycle (the way back is not measured).
        ends = path.point(np.array([path.length_mm, 0.0] * 2))
    else:
        ends = np.vstack([path.vertices_mm[1:]] * 2)
    np.testing.assert_allclose(got, ends, rtol=0, atol=2e-3)


@pytest.mark.parametrize(
    "args, message",
    [
        (("--path", "square", "-o", "p.src"), "--path must be one of line, circle, rectangle"),
        (
            ("--path", "line", "-o", "p.csv"),
            "--path is written in urscript, krl, rapid and fanuc-ls",
        ),
        (
            ("--path", "line", "-o", "p.src", "--path-speed", "0"),
            "--path-speed must be in [1, 5000]",
        ),
        (("--path", "line", "-o", "p.src", "--path-speed", "fast"), "--path-speed must be mm/s"),
        (("--path", "line", "-o", "p.src", "--pulse", "2"), "--pulse is for plan programs"),
        (
            ("plan.csv", "--path", "line", "-o", "p.src"),
            "--path writes the ISO 9283 path, not a plan",
        ),
        (("--path", "line", "-o", "p.src", "--cube", "5000,0,0,300"), "cube"),
        (("-o", "p.src"), "give a PLAN"),
        (("plan.csv", "-o", "p.src", "--cycles", "3"), "--cycles is for --path"),
        (("plan.csv", "-o", "p.src", "--calibration", "c.json"), "--calibration is for --path"),
        (("--path", "line", "-o", "p.src", "--dwell", "0.3"), "holds at least 0.5 s"),
    ],
)
def test_bad_path_options_are_refused_in_one_line_and_nothing_is_written(tmp_path, args, message):
    done = cli("program", *args, cwd=tmp_path)
    assert done.code == 2, done.stdout
    assert message in one_line_error(done)
    assert not (tmp_path / "p.src").exists()
