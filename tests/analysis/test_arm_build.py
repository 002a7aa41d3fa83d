"""``arm.build``: named arms, link-length overrides and poses against chains written out here.

The Craig chain of the paper's arm is multiplied out link by link with scipy
rotations; the MDH arms are compared with :func:`calibrator.model.kinematics.chain`.
"""

import numpy as np
import pytest
from reference_kit import homogeneous as _h
from scipy.spatial.transform import Rotation

from calibrator import robots
from calibrator.analysis import arm
from calibrator.errors import CalibrationError
from calibrator.model import kinematics


def craig_hand(table_deg_mm, pose_deg):
    """Hand pose of a Craig table ``[alpha_{i-1} deg, a_{i-1}, d_i]``, (4, 4)."""
    t = np.eye(4)
    for (alpha, a, d), q in zip(table_deg_mm, pose_deg, strict=True):
        t = t @ _h(Rotation.from_euler("x", alpha, degrees=True)) @ _h(None, (a, 0.0, 0.0))
        t = t @ _h(Rotation.from_euler("z", q, degrees=True)) @ _h(None, (0.0, 0.0, d))
    return t


def test_length_names_follow_each_convention():
    assert arm.length_names("paper") == (
        "a0", "a1", "a2", "a3", "a4", "a5", "d1", "d2", "d3", "d4", "d5", "d6",
    )  # fmt: skip
    assert arm.length_names("ur5e") == (
        "a1", "a2", "a3", "a4", "a5", "a6", "d1", "d2", "d3", "d4", "d5", "d6",
    )  # fmt: skip


def test_the_paper_arm_with_overrides_and_a_pose_is_its_craig_chain():
    table = arm.PAPER_CRAIG.copy()
    table[2, 1] = 250.0  # a2 = a_{i-1} of row 3
    table[2, 2] = 1100.0  # d3
    pose = [10.0, -20.0, 30.0, -40.0, 50.0, -60.0]
    posed = arm.build("Paper", pose_deg=pose, lengths={"a2": 250.0, "d3": 1100.0})
    np.testing.assert_allclose(posed.base2hand(), craig_hand(table, pose)[:3], atol=1e-9)
    assert posed.name == "paper arm (the misalignment paper, Table 2)"
    default = arm.build()
    expected = craig_hand(arm.PAPER_CRAIG, arm.PAPER_POSE_DEG)[:3]
    np.testing.assert_allclose(default.base2hand(), expected, atol=1e-9)


def test_a_named_arm_with_overrides_and_a_pose_is_its_mdh_chain():
    mdh = robots.get("ur5e").mdh.copy()
    mdh[1, kinematics.A] = -500.0  # a2
    mdh[3, kinematics.D] = 150.0  # d4
    pose = np.array([15.0, -70.0, 80.0, -20.0, 45.0, 100.0])
    posed = arm.build("UR5e", pose_deg=pose, lengths={"a2": -500.0, "d4": 150.0})
    expected = kinematics.chain(mdh, np.radians(pose)[np.newaxis])[0]
    np.testing.assert_allclose(posed.base2hand(), expected[:3], atol=1e-9)
    assert posed.name == "ur5e"
    zero = arm.build("ur5e")
    expected = kinematics.chain(robots.get("ur5e").mdh, np.zeros((1, 6)))[0]
    np.testing.assert_allclose(zero.base2hand(), expected[:3], atol=1e-9)


def test_joint_frames_start_at_the_first_link():
    posed = arm.build("ur5e", pose_deg=[30.0, -60.0, 90.0, 0.0, 45.0, 0.0])
    frames = posed.joint_frames()
    np.testing.assert_array_equal(frames[0], posed.links[0])
    np.testing.assert_allclose(arm.compose(frames[-1], posed.tail), posed.base2hand(), atol=1e-12)


def test_an_unknown_length_is_named_with_the_known_ones():
    with pytest.raises(CalibrationError) as info:
        arm.build("ur5e", lengths={"a0": 1.0})
    known = "a1, a2, a3, a4, a5, a6, d1, d2, d3, d4, d5, d6"
    assert str(info.value) == f"unknown link length 'a0' for ur5e; known: {known}"


@pytest.mark.parametrize("pose", [np.zeros(5), [0, 0, np.nan, 0, 0, 0]])
def test_a_pose_must_be_six_finite_angles(pose):
    with pytest.raises(CalibrationError) as info:
        arm.mdh_arm(robots.get("ur5e").mdh, pose)
    assert str(info.value) == (
        f"a pose is six finite joint angles, got shape {np.asarray(pose).shape}"
    )


def test_a_craig_table_must_be_six_by_three():
    with pytest.raises(CalibrationError) as info:
        arm.craig_arm(np.zeros((5, 3)), np.zeros(6))
    assert str(info.value) == "Craig DH table must be 6 x 3, got (5, 3)"
