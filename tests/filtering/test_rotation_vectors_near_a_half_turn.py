"""URScript rotation vectors near 180 deg keep their form and land.

A UR tool pointing down has a rotation vector of length close to pi, where
``r`` and ``r - 2 pi r / |r|`` (the same rotation, about the opposite axis
the other way round) are both within reach of a small correction. A
correction that carries the rotation over the half turn must not flip the
written vector to the other form: a program that blends or interpolates
orientations (``movel`` and ``movep``) would turn the tool the long way
round. Each corrected vector stays within a correction's size of the
program's own, on both sides of pi and in both forms, and the true arm lands
on the intended pose.
"""

from __future__ import annotations

import re

import numpy as np
from filter_kit import calibration, job
from hypothesis import given, settings
from hypothesis import strategies as st

from calibrator.compensate import programs
from calibrator.languages.urscript import reader
from calibrator.model import frames, inverse, kinematics, rotations

LANDS_MM = 0.02
#: Joints of a UR10e with its flange pointing down (rotation vector ~ [2.22, 2.22, 0]).
DOWN = np.array([0.0, -1.57, 1.57, -1.57, -1.57, 0.0])
#: Angles of the targets' rotations: either side of a half turn, down to 2e-5 rad from it.
ANGLES = np.pi + np.array([-3e-3, -5e-4, -1e-4, -2e-5, 2e-5, 1e-4, 5e-4, 3e-3])


def _p(position, rv):
    x, y, z = position / 1000.0
    return f"p[{x:.6f}, {y:.6f}, {z:.6f}, {rv[0]:.7f}, {rv[1]:.7f}, {rv[2]:.7f}]"


def _read(text):
    rows = re.findall(r"movel\(p\[([^\]]*)\]", text)
    return np.array([[float(v) for v in r.split(",")] for r in rows])


def test_a_rotation_near_a_half_turn_keeps_its_form_and_lands(tmp_path):
    cal = calibration("ur10e", seed=2, mm=0.3, rad=0.0005)
    down = kinematics.chain(cal.nominal_mdh, DOWN[None])[0]
    axis0 = rotations.matrix_to_rotvec(down[:3, :3])
    axis0 /= np.linalg.norm(axis0)
    rng = np.random.default_rng(4)
    rvs, targets = [], []
    for angle in ANGLES:
        axis = axis0 + rng.normal(0.0, 0.05, 3)
        axis /= np.linalg.norm(axis)
        rv = angle * axis  # longer than pi for the angles past the half turn: the other form
        pose = frames.transform(rotations.rotvec_to_matrix(rv), down[:3, 3] + rng.normal(0, 30, 3))
        rvs.append(rv)
        targets.append(pose)
    start = inverse.solve(cal.nominal_mdh, np.array(targets), np.tile(DOWN, (len(rvs), 1)))
    assert start.converged.all()
    lines = ["def down():", "  movej([" + ", ".join(f"{v:.6f}" for v in DOWN) + "], a=1.2, v=0.25)"]
    lines += [
        f"  movel({_p(t[:3, 3], rv)}, a=1.2, v=0.25)" for t, rv in zip(targets, rvs, strict=True)
    ]
    src = tmp_path / "down.script"
    src.write_text("\n".join([*lines, "end", ""]))
    out = tmp_path / "out.script"
    summary = programs.Filter("urscript", job(cal), src).run(out, [src])
    assert summary.n_failed == 0, summary.failures
    assert summary.corrected["pose"] == len(ANGLES)
    before, after = _read(src.read_text()), _read(out.read_text())
    np.testing.assert_allclose(before[:, 3:], rvs, atol=1e-6)
    step = np.linalg.norm(after[:, 3:] - before[:, 3:], axis=1)
    assert step.max() < 0.01, step  # the same form: never the 2 pi - |r| long way round
    assert step.min() > 1e-5  # every rotation was corrected
    # Past pi stays past pi where the correction does not carry it back (and v.v.).
    assert (np.linalg.norm(after[:, 3:], axis=1) > np.pi).sum() in range(2, 7)
    sent = reader._decode_pose(after)
    intended = reader._decode_pose(before)
    nominal = inverse.solve(cal.nominal_mdh, sent, start.q)
    assert nominal.converged.all()
    reached = kinematics.chain(cal.mdh, nominal.q)
    miss = np.linalg.norm(reached[:, :3, 3] - intended[:, :3, 3], axis=1)
    assert miss.max() < LANDS_MM, miss
    turn = rotations.rotation_error(reached[:, :3, :3], intended[:, :3, :3])
    assert np.linalg.norm(turn, axis=1).max() < 2e-5


@settings(max_examples=60, deadline=None, derandomize=True)
@given(
    angle=st.floats(np.pi - 0.02, np.pi + 0.02),
    axis=st.tuples(*[st.floats(-1.0, 1.0)] * 3).filter(lambda a: np.linalg.norm(a) > 0.1),
    turn=st.tuples(*[st.floats(-0.01, 0.01)] * 3),
)
def test_the_encoder_writes_the_form_nearest_the_programs_vector(angle, axis, turn):
    """Any rotation within 0.6 deg of a half turn, turned by up to 0.01 rad: the written
    vector is the same rotation, the one of its two forms nearer the program's."""
    old_rv = angle * np.asarray(axis) / np.linalg.norm(axis)
    new = rotations.rotvec_to_matrix(np.asarray(turn)) @ rotations.rotvec_to_matrix(old_rv)
    pose = frames.transform(new, [100.0, -200.0, 300.0])
    old = np.concatenate([[0.1, -0.2, 0.3], old_rv])[None]
    written = reader._encode_pose(pose[None], old)[0]
    np.testing.assert_allclose(written[:3], [0.1, -0.2, 0.3], atol=1e-12)
    np.testing.assert_allclose(rotations.rotvec_to_matrix(written[3:]), new, atol=1e-9)
    assert np.linalg.norm(written[3:] - old_rv) < 0.03
