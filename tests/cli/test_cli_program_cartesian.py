"""``program --targets cartesian``: pose targets a filter can correct.

Each measured pose's URScript move states the nominal model's flange pose at
the plan's joints (m, rotation vector), read back here with a regular
expression and compared with the forward kinematics; home and vias stay
joint targets; a language without Cartesian targets is refused in one line.
"""

import re

import numpy as np
from cli_kit import cli, listing, one_line_error
from plan_kit import CHECKED_PLAN_TRACKER_MM

from calibrator import planning, robots
from calibrator.model import frames, kinematics

_POSE = re.compile(r"^  movej\(p\[([^\]]*)\], a=")
_JOINTS = re.compile(r"^  movej\(\[([^\]]*)\], a=")


def _numbers(text):
    return [float(v) for v in text.split(",")]


def test_pose_moves_state_the_nominal_flange_pose(tmp_path, checked_plan):
    planning.write_plan(tmp_path / "plan.csv", checked_plan)
    at = ",".join(f"{v:g}" for v in CHECKED_PLAN_TRACKER_MM)
    done = cli("program", "plan.csv", "-o", "cell.script", "--targets", "cartesian",
               "--tracker-at", at, cwd=tmp_path)  # fmt: skip
    assert done.code == 0, done.stderr
    lines = (tmp_path / "cell.script").read_text().splitlines()
    poses = [_numbers(m.group(1)) for m in map(_POSE.match, lines) if m]
    joints = [_numbers(m.group(1)) for m in map(_JOINTS.match, lines) if m]
    assert len(poses) == len(checked_plan.q_rad)
    # The vias and home (to and back) stay joint moves.
    assert len(joints) == checked_plan.n_vias
    assert sum(line.startswith("  movej(home, ") for line in lines) == 2
    want = kinematics.chain(robots.get("ur10e").mdh, checked_plan.q_rad)
    got = np.array(poses)
    np.testing.assert_allclose(got[:, :3] * 1000.0, want[:, :3, 3], rtol=0, atol=1e-5)
    turned = frames.rotvec_to_matrix(got[:, 3:])
    np.testing.assert_allclose(turned, want[:, :3, :3], rtol=0, atol=1e-8)


def test_cartesian_targets_in_a_language_without_them_are_refused(tmp_path, checked_plan):
    planning.write_plan(tmp_path / "plan.csv", checked_plan)
    before = listing(tmp_path)
    line = one_line_error(
        cli("program", "plan.csv", "-o", "cell.src", "--targets", "cartesian", cwd=tmp_path)
    )
    assert "--targets cartesian" in line and "krl" in line
    assert listing(tmp_path) == before
