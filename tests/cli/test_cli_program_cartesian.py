"""``program --targets cartesian``: pose targets a filter can correct.

Each measured pose's URScript move states the nominal model's flange pose at
the plan's joints (m, rotation vector), read back here with a regular
expression and compared with the forward kinematics; home and vias stay
joint targets; a language without Cartesian targets is refused in one line.
"""

import re

import numpy as np
from cli_kit import cli, listing, one_line_error
from export_kit import calibrated
from plan_kit import CHECKED_PLAN_TRACKER_MM

from calibrator import planning, robots
from calibrator.languages import configuration
from calibrator.model import kinematics, rotations

_POSE = re.compile(r"^  movej\(p\[([^\]]*)\], a=")
_JOINTS = re.compile(r"^  movej\(\[([^\]]*)\], a=")


def _numbers(text):
    return [float(v) for v in text.split(",")]


def _write(tmp_path, plan, *more):
    planning.write_plan(tmp_path / "plan.csv", plan)
    at = ",".join(f"{v:g}" for v in CHECKED_PLAN_TRACKER_MM)
    done = cli("program", "plan.csv", "-o", "cell.script", "--targets", "cartesian",
               "--tracker-at", at, *more, cwd=tmp_path)  # fmt: skip
    assert done.code == 0, done.stderr
    return (tmp_path / "cell.script").read_text().splitlines()


def test_pose_moves_state_the_nominal_flange_pose(tmp_path, checked_plan):
    lines = _write(tmp_path, checked_plan)
    poses = [_numbers(m.group(1)) for m in map(_POSE.match, lines) if m]
    assert len(poses) == len(checked_plan.q_rad)
    want = kinematics.chain(robots.get("ur10e").mdh, checked_plan.q_rad)
    got = np.array(poses)
    np.testing.assert_allclose(got[:, :3] * 1000.0, want[:, :3, 3], rtol=0, atol=1e-5)
    turned = rotations.rotvec_to_matrix(got[:, 3:])
    np.testing.assert_allclose(turned, want[:, :3, :3], rtol=0, atol=1e-8)
    assert sum(line.startswith("  movej(home, ") for line in lines) == 2


def test_each_pose_comes_from_joints_whose_nearest_solution_is_the_plans(tmp_path, checked_plan):
    """The controller solves a pose nearest the joints it comes from: those are in the
    plan's configuration and less than half a turn from its joints on every axis."""
    lines = _write(tmp_path, checked_plan)
    mdh = robots.get("ur10e").mdh
    q = checked_plan.q_rad
    home = _numbers(re.match(r"^  home = \[([^\]]*)\]$", lines[4]).group(1))
    here, pose, approaches = np.array(home), 0, 0
    for line in lines:
        joints, target = _JOINTS.match(line), _POSE.match(line)
        if joints:
            here = np.array(_numbers(joints.group(1)))
            approaches += bool(pose < len(q) and np.abs(here - q[pose]).max() < 1e-8)
        elif target:
            bits = configuration.arm_bits(mdh, np.array([here, q[pose]]))
            assert (bits[0] == bits[1]).all(), (pose, bits)
            assert np.abs(q[pose] - here).max() < np.pi, pose
            here, pose = q[pose], pose + 1
    assert pose == len(q)
    joint_moves = sum(bool(_JOINTS.match(line)) for line in lines)
    # The plan's vias, and a move to a pose's own joints only where it is needed.
    assert joint_moves == checked_plan.n_vias + approaches and approaches < len(q)


def test_compensate_corrects_every_pose_target(tmp_path, checked_plan):
    _write(tmp_path, checked_plan)
    calibrated("ur10e", seed=3, mm=0.3, rad=0.001).save(tmp_path / "cal.json")
    done = cli("compensate", "cal.json", "cell.script", "-o", "out.script", cwd=tmp_path)
    assert done.code == 0, done.stderr
    n = len(checked_plan.q_rad)
    assert f"{n} pose target(s): {n} corrected, 0 kept, 0 failed" in done.stdout
    before = (tmp_path / "cell.script").read_text().splitlines()
    after = (tmp_path / "out.script").read_text().splitlines()
    changed = [b for a, b in zip(before, after, strict=True) if a != b]
    assert len(changed) == n and all(_POSE.match(b) for b in changed)


def test_cartesian_targets_in_a_language_without_them_are_refused(tmp_path, checked_plan):
    planning.write_plan(tmp_path / "plan.csv", checked_plan)
    before = listing(tmp_path)
    line = one_line_error(
        cli("program", "plan.csv", "-o", "cell.src", "--targets", "cartesian", cwd=tmp_path)
    )
    assert "--targets cartesian" in line and "krl" in line
    assert listing(tmp_path) == before
