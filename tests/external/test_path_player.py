"""The external-robot simulator's controller reads each language's path program as written.

The player (``drivers.robot.external_sim.path_program``) interpolates the
program's moves as a controller does; its flange path, taken to the
reflector through the arm's controller frames, must run on verify's
commanded circle at the program's stated speed, with the holds it states.
"""

from __future__ import annotations

import numpy as np
import pytest
from cli_kit import cli
from path_kit import commanded, reflector

from calibrator import robots
from calibrator.model import frames, kinematics
from drivers.robot.external_sim import path_program

ARMS = [
    ("ur10e", "p.script"),
    ("kuka-kr6-r900", "p.src"),
    ("abb-irb4600-60-205", "p.mod"),
    ("fanuc-m20ia", "p.ls"),
]
SPEED = 150.0


@pytest.mark.parametrize("name, output", ARMS, ids=[o for _, o in ARMS])
def test_the_players_flange_path_runs_on_the_commanded_circle_at_the_stated_speed(
    tmp_path, name, output
):
    done = cli(
        "program", "--path", "circle", "--model", name, "-o", output, "--path-speed",
        str(int(SPEED)), "--cycles", "2", "--dwell", "1", cwd=tmp_path,
    )  # fmt: skip
    assert done.code == 0, done.stderr
    arm = robots.get(name)
    program = path_program.read(tmp_path / output)
    q = arm.convention.to_model(program.start_rad[None])
    base, flange = arm.model_base2controller_base, arm.model_flange2controller_flange
    start = frames.invert(base) @ kinematics.chain(arm.mdh, q)[0] @ flange
    t, poses = path_program.flange_path(program, start)
    at = reflector(arm, poses)
    path, _ = commanded(arm, "circle")
    rel = at - path.centre_mm
    # On the circle: in its plane, at its radius (Fanuc writes positions to 1 um).
    assert np.abs(rel @ path.normal).max() < 5e-3
    assert np.abs(np.linalg.norm(rel, axis=1) - path.radius_mm).max() < 5e-3
    # At the stated speed between the ramps; two cycles of one circle each, three 1 s holds.
    v = np.linalg.norm(np.diff(at, axis=0), axis=1) / np.diff(t)
    assert np.max(v) == pytest.approx(SPEED, rel=1e-3)
    moving = np.sum(np.diff(t)[v > 1.0])
    ramp = SPEED / path_program.DEFAULT_ACCEL_MM_S2  # every language here states 2 m/s^2
    assert moving == pytest.approx(2 * (path.length_mm / SPEED + ramp), abs=0.02)
    assert t[-1] == pytest.approx(moving + 3.0, abs=0.02)


def test_the_player_refuses_what_a_path_program_does_not_have_in_one_line(tmp_path):
    import subprocess
    import sys

    from cli_process_kit import child_env

    (tmp_path / "p.src").write_text("DEF P()\nEND\n")
    for args, message in (
        (["--skip", "3"], "--skip and --pause are for --plan"),
        ([], "no PTP to the path's start"),
    ):
        done = subprocess.run(
            [sys.executable, "-m", "drivers.robot.external_sim", "--program", "p.src",
             "--control", "socket://127.0.0.1:9", *args],
            cwd=tmp_path, capture_output=True, text=True, env=child_env(None), timeout=120,
        )  # fmt: skip
        assert done.returncode == 2, done.stderr
        lines = done.stderr.strip().splitlines()
        assert len(lines) == 1 and message in lines[0]
