"""Planned poses keep a stated distance from the arm's singularities."""

import numpy as np
import pytest

from calibrator import cell as cells
from calibrator import planning, robots
from calibrator.cell import checks
from calibrator.model import singularities

UR10E = robots.get("ur10e")
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


def test_the_shoulder_bound_is_the_wrist_centres_distance_from_the_shoulder_plane():
    # On a UR arm the wrist centre sweeps the plane through axis 1 parallel to axis 2
    # as q3 bends the arm back over its base: find that q3, then step off it.
    chk = checker(UR10E)

    def margin(q3):
        q = np.array([[0.4, -1.9, q3, -1.0, 1.2, 0.0]])
        return singularities.margins(UR10E.mdh, q)[0, 2], q

    def sign(q3):  # which side of the plane (its normal: x of the frame on axis 2, level)
        _, _, w, x1, *_ = singularities.points(UR10E.mdh, margin(q3)[1])
        return np.sign(w[0, :2] @ x1[0, :2])

    grid = np.linspace(-2.8, 2.8, 57)
    flips = [k for k in range(len(grid) - 1) if sign(grid[k]) != sign(grid[k + 1])]
    lo, hi = grid[flips[0]], grid[flips[0] + 1]
    assert sign(lo) != sign(hi)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if sign(mid) == sign(lo) else (lo, mid)
    on, q_on = margin(lo)
    assert on < 1e-6
    assert checks.singularity_faults(chk, q_on)[0].tolist() == [False, False, True]
    off = np.array([[0.4, -1.9, lo - 0.3, -1.0, 1.2, 0.0]])
    assert singularities.margins(UR10E.mdh, off)[0, 2] > checks.SHOULDER_MIN_MM
    assert not checks.singularity_faults(chk, off)[0, 2]


@pytest.mark.parametrize("n", [30])
def test_planned_poses_keep_clear_of_every_singularity(n):
    made = planning.make_checked(UR10E, n, TRACKER, (0.0, 0.0, 100.0))
    q = made.plan.q_rad
    assert not checks.singularity_faults(checker(UR10E), q).any()
    assert np.abs(np.sin(q[:, 4])).min() >= np.sin(np.radians(checks.WRIST_MIN_DEG))
    assert np.abs(np.sin(q[:, 2])).min() >= np.sin(np.radians(checks.ELBOW_MIN_DEG))
    for reason in checks.SINGULARITY_REASONS[:2]:
        assert made.dropped[reason] > 0  # the filter ran and had work to do
