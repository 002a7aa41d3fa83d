"""URScript: a pose right after a joint target is solved nearest those joints.

The controller solves ``movej(p[...])`` nearest the joints it comes from.
After a joint target in another configuration than the pose before it
(the wrist flipped), the pose's corrected target must be the one for that
joint target's configuration: sent to a nominal controller that solves it
from there, the true arm lands on the intended pose.
"""

import re

import numpy as np
from filter_kit import calibration, job, landed, work_joints

from calibrator.compensate import programs
from calibrator.languages import configuration
from calibrator.model import frames, kinematics, rotations

FLANGE = np.eye(4)


def _p(pose):
    rv = rotations.matrix_to_rotvec(pose[:3, :3])
    x, y, z = pose[:3, 3] / 1000.0
    return f"p[{x:.9f}, {y:.9f}, {z:.9f}, {rv[0]:.9f}, {rv[1]:.9f}, {rv[2]:.9f}]"


def _joints(q):
    return "[" + ", ".join(f"{v:.9f}" for v in q) + "]"


def test_a_pose_after_a_joint_target_takes_that_targets_configuration(tmp_path):
    cal = calibration("ur10e")
    q_a = work_joints(1, seed=4, model="ur10e")[0]
    # The pose of q_near (close to q_a) with the wrist flipped: another configuration.
    # Solved from q_a it is q_near, in q_a's configuration; the controller, coming
    # from q_b, solves it in q_b's (the old filter's correction missed by 1e-3 mm and more).
    q_near = q_a + np.radians([2.0, -3.0, 2.0, 4.0, -3.0, 5.0])
    q_b = q_near + [0.0, 0.0, 0.0, np.pi, 0.0, np.pi]
    q_b[4] = -q_near[4]
    bits = configuration.arm_bits(cal.nominal_mdh, np.array([q_a, q_b]))
    assert bits[0, 2] != bits[1, 2]
    intended = kinematics.tool_poses(cal.nominal_mdh, np.array([q_a, q_b]), FLANGE)
    src = tmp_path / "prog.script"
    src.write_text(
        "def prog():\n"
        f"  movej({_joints(q_a)}, a=1.2, v=0.25)\n"
        f"  movej({_p(intended[0])}, a=1.2, v=0.25)\n"
        f"  movej({_joints(q_b)}, a=1.2, v=0.25)\n"
        f"  movej({_p(intended[1])}, a=1.2, v=0.25)\n"
        "end\n"
    )
    out = tmp_path / "out.script"
    summary = programs.Filter("urscript", job(cal), src).run(out, [src])
    assert summary.n_failed == 0, summary.failures
    assert summary.corrected["pose"] == 2
    written = [
        [float(v) for v in m.group(1).split(",")]
        for m in re.finditer(r"p\[([^\]]*)\]", out.read_text())
    ]
    for pose, q_from, want in zip(written, (q_a, q_b), intended, strict=True):
        sent = frames.transform(rotations.rotvec_to_matrix(pose[3:]), np.array(pose[:3]) * 1000.0)
        # The nominal controller solves it from the joints the arm comes from.
        got, q = landed(cal.mdh, cal.nominal_mdh, sent[None], FLANGE, q_from[None])
        assert (configuration.arm_bits(cal.nominal_mdh, q) == configuration.arm_bits(
            cal.nominal_mdh, q_from[None])).all()  # fmt: skip
        np.testing.assert_allclose(got[0, :3, 3], want[:3, 3], rtol=0, atol=1e-3)
