"""The one whole-plan check before motion (calibrator/planning/checks.py): limits, count, cell."""

import numpy as np
import pytest

from calibrator import planning, robots
from calibrator.model import frames

UR10E = robots.get("ur10e")
TOOL = frames.transform(translation=[0.0, 0.0, 100.0])
TOOL_MM = (0.0, 0.0, 100.0)
LIMITS = np.tile([-2.0, 3.0], (6, 1))


def test_a_plan_on_its_limits_is_valid_and_comes_back_as_floats():
    q = [[-2, 3, 0, 0, 0, 0]] * 4 + [[3, -2, 0, 0, 0, 0]]  # integers, on the limits
    out = planning.check_limits(q, LIMITS.astype(int), need=5)
    assert out.dtype == float and out.shape == (5, 6)
    np.testing.assert_array_equal(out, q)


@pytest.mark.parametrize(
    ("q", "message"),
    [
        (np.zeros((5, 5)), r"a plan needs 6 joint angles per pose, got shape \(5, 5\)"),
        (np.zeros(6), r"got shape \(6,\)"),
        (np.zeros((2, 6, 1)), r"got shape \(2, 6, 1\)"),
    ],
)
def test_a_plan_of_the_wrong_shape_is_refused(q, message):
    with pytest.raises(planning.PlanError, match=message):
        planning.check_limits(q, LIMITS)


@pytest.mark.parametrize(
    ("row", "joint", "value"),
    [(3, 0, -2.0000001), (1, 5, 3.0000001), (4, 2, np.nan)],
)
def test_a_joint_past_its_limit_is_named(row, joint, value):
    q = np.zeros((6, 6))
    q[row, joint] = value
    q[5, 1] = 99.0  # a later row is not the one named
    with pytest.raises(planning.PlanError) as exc:
        planning.check_limits(q, LIMITS)
    assert str(exc.value) == (
        f"plan row {row} joint {joint + 1}: {value:.6g} rad outside [-2, 3]; nothing moved"
    )


def test_exactly_the_needed_poses_are_enough():
    assert len(planning.check_limits(np.zeros((9, 6)), LIMITS, need=9)) == 9
    with pytest.raises(planning.PlanError, match="^plan has 8 poses; the free .* at least 9$"):
        planning.check_limits(np.zeros((8, 6)), LIMITS, need=9)


def test_validate_refuses_whole_plan_out_of_limits_or_too_short():
    q = np.zeros((12, 6))
    q[7, 2] = 3.5  # elbow beyond pi
    with pytest.raises(planning.PlanError, match="plan row 7 joint 3"):
        planning.check_limits(q, UR10E.joint_limits_rad)
    need = planning.min_poses(UR10E.mdh)
    assert 8 <= need <= 12
    with pytest.raises(planning.PlanError, match=f"need at least {need}"):
        planning.check_limits(np.zeros((need - 1, 6)), UR10E.joint_limits_rad, need=need)
