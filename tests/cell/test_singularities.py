"""Planned poses keep a stated distance from the arm's singularities."""

import numpy as np
import pytest

from calibrator import cell as cells
from calibrator import kinematics
from calibrator import plan as plans
from calibrator.cell import checks
from calibrator.models import get_model

UR10E = get_model("ur10e")
TRACKER = cells.Cell(tracker_at_mm=(2500.0, 400.0, 300.0))


def checker(model):
    return cells.checker(cells.arm_geometry(model.name, model.mdh, (0.0, 0.0, 100.0)), TRACKER)


@pytest.mark.parametrize("joint", [4, 2])  # q5 (wrist), q3 (elbow), zero-based
def test_on_a_ur_arm_the_wrist_and_elbow_bounds_are_sin_q5_and_sin_q3(joint):
    chk = checker(UR10E)
    q = np.tile([0.3, -1.2, 1.0, -1.5, 1.0, 0.2], (6, 1))
    bound = checks.WRIST_MIN_DEG if joint == 4 else checks.ELBOW_MIN_DEG
    q[:, joint] = np.radians(
        [0.0, bound - 0.1, -(bound - 0.1), bound + 0.1, 180.0 - (bound - 0.1), 90]
    )
    column = 0 if joint == 4 else 1
    faults = checks.singularity_faults(chk, q)
    assert faults[:, column].tolist() == [True, True, True, False, True, False]
    assert not faults[:, [c for c in range(3) if c != column]].any()


def test_the_shoulder_bound_is_the_wrist_centres_distance_from_axis_1():
    model = get_model("er10l-c10")  # a spherical wrist that can reach over its base
    chk = checker(model)
    rng = np.random.default_rng(1)
    q = rng.uniform(-np.pi, np.pi, (4000, 6))
    _, frames = kinematics.chain(model.mdh, q, all_frames=True)
    radial = np.linalg.norm(frames[:, 4, :2, 3], axis=1)
    near = checks.singularity_faults(chk, q)[:, 2]
    assert near.any() and (~near).any()
    assert np.array_equal(near, radial < checks.SHOULDER_MIN_MM)


@pytest.mark.parametrize("n", [30])
def test_planned_poses_keep_clear_of_every_singularity(n):
    made = plans.make_checked(UR10E, n, TRACKER, (0.0, 0.0, 100.0))
    q = made.plan.q_rad
    assert not checks.singularity_faults(checker(UR10E), q).any()
    assert np.abs(np.sin(q[:, 4])).min() >= np.sin(np.radians(checks.WRIST_MIN_DEG))
    assert np.abs(np.sin(q[:, 2])).min() >= np.sin(np.radians(checks.ELBOW_MIN_DEG))
    for reason in checks.SINGULARITY_REASONS[:2]:
        assert made.dropped[reason] > 0  # the filter ran and had work to do
