"""Simulated arms for identification tests: any tool frame, extra joint errors.

:func:`calibrator.simulate.simulate` covers the usual sessions; the cases
here need what it does not offer: a probe mounted at an arbitrary rotation,
a tool point placed exactly, joint-2/3 compliance under gravity in the
truth, an outlier pose, the same poses under many noise draws.
"""

import numpy as np

from calibrator import robots, session
from calibrator.model import kinematics, rotations
from calibrator.simulate import random_errors, sample_joints


def truth_arm(model="er10l-c10", seed=0):
    """Nominal table and a true table with seed-sized random errors."""
    robot = robots.get(model)
    rng = np.random.default_rng(seed)
    return robot, robot.mdh + random_errors(robot.mdh, rng)


def joints(robot, n, seed):
    return sample_joints(robot.joint_limits_rad, n, np.random.default_rng(seed))


def measure(true_mdh, q, tool, base=None, compliance_rad=0.0):
    """True tool poses (N, 4, 4) in the tracker frame.

    ``compliance_rad`` bends joints 2 and 3 under gravity: each turns by
    ``compliance_rad * cos`` of its link's angle to the horizontal, an
    error no MDH table expresses.
    """
    q = np.array(q, dtype=float)
    if compliance_rad:
        q2 = q[:, 1].copy()
        q[:, 1] += compliance_rad * np.cos(q2)
        q[:, 2] += compliance_rad * np.cos(q2 + q[:, 2])
    return kinematics.forward(true_mdh, q, tool, base)


def loaded(
    robot,
    q,
    pose,
    *,
    orientation=True,
    noise_mm=0.0,
    noise_rad=0.0,
    seed=0,
    tool_guess=None,
    tool_known=False,
    frame="base",
):
    """A Session of measured ``pose`` (N, 4, 4) with isotropic Gaussian noise."""
    rng = np.random.default_rng(seed)
    points = pose[:, :3, 3] + rng.normal(0.0, noise_mm, (len(q), 3))
    rot = pose[:, :3, :3]
    if noise_rad:
        rot = rotations.rotvec_to_matrix(rng.normal(0.0, noise_rad, (len(q), 3))) @ rot
    table = session.to_table(
        q, points, rotvecs=rotations.matrix_to_rotvec(rot) if orientation else None
    )
    meta = session.SessionMeta(
        frame=frame,
        nominal_mdh=robot.mdh,
        model=robot.name,
        flange2tool=np.eye(4) if tool_guess is None else tool_guess,
        tool_known=tool_known,
    )
    return session.Session(table, meta)
