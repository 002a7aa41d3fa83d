"""A written program states what was asked, or the command refuses: names, speeds, angles.

No speed is rounded to zero or made faster, no angle rounded past a joint
limit, no program named with a keyword or a name it calls, and no program
renamed away from its file where the controller requires the two to agree.
"""

import math
import re

import numpy as np
import pytest
from cli_kit import cli, listing, one_line_error
from grammar_kit import PARSERS

from calibrator import planning, robots
from calibrator.languages import writing as programs

ARM = robots.get("ur10e")


def _spec(q, **kw):
    args = dict(
        plan_rad=q,
        home_rad=q[0],
        speed_rad_s=ARM.move_speed_cap_rad_s,
        accel_rad_s2=ARM.move_accel_cap_rad_s2,
        max_joint_speed_rad_s=ARM.max_joint_speed_rad_s,
        name="cal_run",
        model=ARM.name,
        joint_limits_rad=ARM.joint_limits_rad,
    )
    args.update(kw)
    return programs.ProgramSpec(**args)


@pytest.fixture
def folder(tmp_path, checked_plan):
    planning.write_plan(tmp_path / "plan.csv", checked_plan)
    return tmp_path


def _refused(folder, *args):
    before = listing(folder)
    line = one_line_error(cli("program", "plan.csv", *args, cwd=folder))
    assert listing(folder) == before
    return line


@pytest.mark.parametrize("name", ["DEF.src", "PTP.src", "END.src", "wait.src"])
def test_krl_refuses_a_keyword_or_a_name_the_program_uses_as_its_file_name(folder, name):
    # KSS names the program after its file: renaming it inside would not load.
    line = _refused(folder, "-o", name)
    assert "keyword or a name the program uses" in line


@pytest.mark.parametrize(
    ("name", "fmt", "expected"),
    [
        ("end.script", "urscript", "def end_program():"),
        ("movej.script", "urscript", "def movej_program():"),
        ("run.script", "urscript", "def run_program():"),
        ("cal.script", "urscript", "def cal():"),
        ("main.mod", "rapid", "MODULE MainProgram"),
        ("ENDMODULE.mod", "rapid", "MODULE EndmoduleProgram"),
    ],
)
def test_urscript_and_rapid_never_use_a_keyword_or_a_called_name(folder, name, fmt, expected):
    # Their procedure or module name may differ from the file's: it gets _program.
    done = cli("program", "plan.csv", "-o", name, cwd=folder)
    assert done.code == 0, done.stderr
    text = (folder / name).read_text()
    assert expected in text
    PARSERS[fmt](text)  # still every statement of the language


@pytest.mark.parametrize(
    "name", ["a-b.src", "1run.src", "x" * 25 + ".src", "a-b.ls", "x" * 37 + ".ls", "émile.src"]
)
def test_krl_and_fanuc_programs_are_named_as_their_file_or_refused(folder, name):
    line = _refused(folder, "-o", name)
    assert "after its file" in line


def test_krl_def_matches_a_long_valid_file_name(folder):
    name = "calibration_run_2026_11"  # 23 characters
    done = cli("program", "plan.csv", "-o", f"{name}.src", cwd=folder)
    assert done.code == 0, done.stderr
    assert (folder / f"{name}.src").read_text().startswith(f"DEF {name.upper()}()")


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (("--dwell", "1e300"), "--dwell"),
        (("--pulse", "99999999999999999999"), "--pulse"),
        (("--pulse", "5000"), "--pulse"),
        (("--speed", "1e-5"), "--speed"),
        (("--speed", "1e-300"), "--speed"),
        (("--accel", "1e-6"), "--accel"),
    ],
)
def test_unbounded_values_are_refused(folder, args, needle):
    assert needle in _refused(folder, "-o", "cal.script", *args)


def test_a_urscript_pulse_beyond_its_outputs_is_refused(folder):
    assert "0-7" in _refused(folder, "-o", "cal.script", "--pulse", "8")


def test_krl_refuses_a_speed_it_cannot_state_rather_than_move_faster(folder):
    # 0.1 % of the fastest UR10e axis (3.14 rad/s) is 3.1e-3 rad/s.
    line = _refused(folder, "-o", "cal.src", "--speed", "0.002")
    assert "slowest KRL can state" in line
    done = cli("program", "plan.csv", "-o", "cal.src", "--speed", "0.01", cwd=folder)
    assert done.code == 0, done.stderr


@pytest.mark.parametrize("speed", [0.0123, 0.001, 0.25])
def test_urscript_writes_the_speed_asked(speed):
    q = np.zeros((2, 6)) + [[0.1], [0.2]]
    text = programs.render(_spec(q, speed_rad_s=speed, accel_rad_s2=speed), "urscript")
    values = {float(v) for v in re.findall(r"v=([0-9.e-]+)", text)}
    accels = {float(v) for v in re.findall(r"a=([0-9.e-]+)", text)}
    assert values == {speed} and accels == {speed}


@pytest.mark.parametrize("fmt", ["urscript", "krl", "rapid", "fanuc-ls", "csv"])
def test_an_angle_at_a_limit_is_never_written_past_it(fmt):
    q = np.zeros((2, 6))
    q[0, 2] = math.pi  # q3 exactly at its limit
    q[1, 2] = -math.pi
    q[1, 0] = ARM.joint_limits_rad[0, 1]
    text = programs.render(_spec(q, pulse_output=1), fmt)
    if fmt == "csv":
        rows = [line.split(",") for line in text.splitlines()[1:]]
        written = np.array([[float(v) for v in r[9:15]] for r in rows])  # q1_rad..q6_rad
        written_deg = np.radians([[float(v) for v in r[3:9]] for r in rows])
        written = np.vstack([written, written_deg])
    else:
        written = np.array(PARSERS[fmt](text).targets())
    lo, hi = ARM.joint_limits_rad[:, 0], ARM.joint_limits_rad[:, 1]
    assert np.all(written <= hi) and np.all(written >= lo)
    np.testing.assert_allclose(written[1:3], q, atol=2e-6)
