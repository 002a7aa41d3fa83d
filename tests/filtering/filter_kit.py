"""Programs and calibrations for the filter tests: targets from known joints.

Each program is written the way its vendor's reference shows, from joint
values chosen in a work box clear of singularities: the nominal pose of those
joints (in a tool and a base) is the intended pose, and the configuration
data is read off the joints.
"""

from __future__ import annotations

import numpy as np

from calibrator import robots, simulate
from calibrator.calibration import Calibration
from calibrator.languages import configuration, frames_file
from calibrator.languages.reading import Job
from calibrator.model import frames, inverse, kinematics, parameters, rotations

TOOL = frames.transform(rotations.zyx_to_matrix([[0.0, 30.0, 0.0]])[0], [12.5, -4.0, 180.0])
TOOL2 = frames.transform(rotations.zyx_to_matrix([[90.0, 0.0, 0.0]])[0], [0.0, 40.0, 120.0])
BASE = frames.transform(rotations.zyx_to_matrix([[25.0, 0.0, 0.0]])[0], [900.0, -250.0, 120.0])


def calibration(model="er10l-c10", seed=3, mm=0.3, rad=0.0005):
    """A calibration of ``model`` with random MDH errors (none for mm = rad = 0)."""
    nominal = robots.get(model).mdh
    rng = np.random.default_rng(seed)
    errors = simulate.random_errors(nominal, rng, mm=mm, rad=rad) if mm or rad else np.zeros((6, 5))
    free = tuple(np.array(parameters.MDH_NAMES)[errors.ravel() != 0])
    deltas = dict(zip(free, errors.ravel()[errors.ravel() != 0], strict=False))
    return Calibration(
        nominal_mdh=nominal, mdh=nominal + errors, model=model, free=free, deltas=deltas
    )


def work_joints(n, seed=0, model="er10l-c10"):
    """Joints (N, 6) rad in a work box in front of the arm, clear of singularities."""
    rng = np.random.default_rng(seed)
    if model.startswith("ur"):
        box = [(-1.0, 1.0), (-2.2, -1.0), (0.6, 2.0), (-2.5, -0.5), (0.5, 2.5), (-3.0, 3.0)]
    else:
        box = [(-0.8, 0.8), (-0.2, 0.6), (-0.6, 0.2), (-1.2, 1.2), (0.4, 1.5), (-2.5, 2.5)]
    return np.column_stack([rng.uniform(lo, hi, n) for lo, hi in box])


def poses(cal, q, tool=TOOL, base=BASE):
    """Nominal tool poses (N, 4, 4) of joints ``q`` in frame ``base`` (mm)."""
    return frames.invert(base) @ kinematics.tool_poses(cal.nominal_mdh, q, tool)


def job(cal, frames_table=None, **kw):
    return Job(
        calibration=cal,
        frames=frames_table or frames_file.FrameTable(),
        limits=robots.get(cal.model).joint_limits_rad,
        **kw,
    )


def landed(truth_mdh, nominal_mdh, written_pose_base, tool, q_start, conf_check=None):
    """Where the true arm lands when a nominal controller is sent base-frame poses.

    The nominal controller solves its own model's inverse kinematics (same
    configuration: started from the joints the target was made from), and the
    true arm turns to those joints.
    """
    sol = inverse.solve(nominal_mdh, written_pose_base, q_start, tool)
    assert sol.converged.all()
    return kinematics.chain(truth_mdh, sol.q) @ tool, sol.q


def bits(cal, q):
    return configuration.arm_bits(cal.nominal_mdh, q)


def path_joints(n, seed=0, model="er10l-c10"):
    """Joints (N, 6) along a path between two work-box poses (programs move in steps)."""
    ends = work_joints(2, seed, model)
    t = np.linspace(0.0, 1.0, n)[:, None]
    return ends[0] + t * (ends[1] - ends[0])


def frame_yaml(t):
    """One ``--frames`` entry (flow YAML) for a transform (4, 4)."""
    abc = rotations.matrix_to_zyx(t[None, :3, :3], np.zeros((1, 3)))[0]
    xyz = ", ".join(str(v) for v in t[:3, 3])
    return f"{{xyz_mm: [{xyz}], abc_deg: [{abc[0]}, {abc[1]}, {abc[2]}]}}"
