"""The named models against their published sources, number by number.

The tables below are typed from the sources, not from ``calibrator.robots``:

- Universal Robots, "DH parameters for calculations of kinematics and
  dynamics" (UR support article): standard DH, metres and radians,
  alpha = (pi/2, 0, 0, pi/2, -pi/2, 0) on all three arms.
- Joint limits and speeds: UR's ROS 2 description (tag 2.4.5,
  ``config/<model>/joint_limits.yaml``): +-360 deg on every joint but the
  elbow (+-180 deg); speeds 180 deg/s on the UR5e, 120 deg/s on the first two
  joints and 180 deg/s on the others on the UR10 and UR10e.
- ER10L-C10: the IPSO paper, Table 1 (a mm, alpha deg, theta deg, d mm), and its
  simulation range [-pi, pi] on every joint.
"""

import numpy as np
import pytest

from calibrator import robots
from calibrator.errors import CalibrationError
from calibrator.model.kinematics import ALPHA, BETA, THETA, A, D

# name: (d1, a2, a3, d4, d5, d6) in metres, from UR's DH article.
UR_DH_M = {
    "ur5e": (0.1625, -0.425, -0.3922, 0.1333, 0.0997, 0.0996),
    "ur10e": (0.1807, -0.6127, -0.57155, 0.17415, 0.11985, 0.11655),
    "ur10": (0.1273, -0.612, -0.5723, 0.163941, 0.1157, 0.0922),
}
UR_ALPHA = (np.pi / 2, 0.0, 0.0, np.pi / 2, -np.pi / 2, 0.0)
UR_SPEED_DEG_S = {
    "ur5e": (180, 180, 180, 180, 180, 180),
    "ur10e": (120, 120, 180, 180, 180, 180),
    "ur10": (120, 120, 180, 180, 180, 180),
}
# The IPSO paper, Table 1: joint, a (mm), alpha (deg), theta (deg), d (mm).
ER10L_TABLE_1 = (
    (170.0, -90.0, 0.0, 0.0),
    (780.0, 0.0, -90.0, 0.0),
    (140.0, -90.0, 0.0, 0.0),
    (0.0, 90.0, 0.0, 1060.0),
    (0.0, -90.0, 0.0, 0.0),
    (0.0, 0.0, 0.0, 125.0),
)


@pytest.mark.parametrize("name", sorted(UR_DH_M))
def test_ur_tables_are_the_published_dh_parameters(name):
    d1, a2, a3, d4, d5, d6 = UR_DH_M[name]
    mdh = robots.get(name).mdh
    assert mdh.shape == (6, 5)
    assert mdh.dtype == np.float64
    np.testing.assert_allclose(mdh[:, A], np.array([0, a2, a3, 0, 0, 0]) * 1000, atol=1e-9)
    np.testing.assert_allclose(mdh[:, D], np.array([d1, 0, 0, d4, d5, d6]) * 1000, atol=1e-9)
    np.testing.assert_allclose(mdh[:, ALPHA], UR_ALPHA, atol=1e-15)
    np.testing.assert_array_equal(mdh[:, THETA], np.zeros(6))
    np.testing.assert_array_equal(mdh[:, BETA], np.zeros(6))


@pytest.mark.parametrize("name", sorted(UR_DH_M))
def test_ur_limits_and_speeds_are_those_of_the_ros_description(name):
    m = robots.get(name)
    two_turns = np.radians(360.0)
    expected = np.array([[-two_turns, two_turns]] * 6)
    expected[2] = [-np.pi, np.pi]
    np.testing.assert_allclose(m.joint_limits_rad, expected, rtol=1e-15)
    np.testing.assert_allclose(
        m.max_joint_speed_rad_s, np.radians(UR_SPEED_DEG_S[name]), rtol=1e-15
    )
    assert m.joint_limits_rad.shape == (6, 2)
    assert m.max_joint_speed_rad_s.shape == (6,)


def test_er10l_table_is_table_1_of_the_seed():
    mdh = robots.get("er10l-c10").mdh
    table = np.array(ER10L_TABLE_1)
    np.testing.assert_allclose(mdh[:, A], table[:, 0], atol=1e-12)
    np.testing.assert_allclose(mdh[:, ALPHA], np.radians(table[:, 1]), atol=1e-15)
    np.testing.assert_allclose(mdh[:, THETA], np.radians(table[:, 2]), atol=1e-15)
    np.testing.assert_allclose(mdh[:, D], table[:, 3], atol=1e-12)
    np.testing.assert_array_equal(mdh[:, BETA], np.zeros(6))


def test_er10l_joint_range_is_the_seeds_simulation_range():
    limits = robots.get("er10l-c10").joint_limits_rad
    np.testing.assert_allclose(limits, np.tile([-np.pi, np.pi], (6, 1)), rtol=1e-15)


def test_model_tables_are_read_only_and_fresh_per_call():
    m = robots.get("ur10e")
    for field in (m.mdh, m.joint_limits_rad, m.max_joint_speed_rad_s):
        with pytest.raises(ValueError, match="read-only"):
            field[0] = 1.0
    assert robots.get("ur10e").mdh is not m.mdh


def test_names_are_matched_without_case_or_surrounding_spaces():
    m = robots.get("  UR10E \n")
    assert m.name == "ur10e"
    np.testing.assert_array_equal(m.mdh, robots.get("ur10e").mdh)
    assert {"er10l-c10", "ur10", "ur10e", "ur5e"} <= set(robots.names())
    assert robots.names() == tuple(sorted(robots.names()))


def test_an_unknown_name_is_refused_with_the_known_ones():
    with pytest.raises(CalibrationError) as info:
        robots.get("kr16")
    assert str(info.value) == f"unknown model 'kr16'; known: {', '.join(robots.names())}"
    assert "er10l-c10, fanuc-m20ia, kuka-kr6-r900" in str(info.value)


def test_a_model_built_from_integer_lists_holds_read_only_float_arrays():
    m = robots.RobotDescription("arm", [[1, 0, 0, 2, 0]] * 6, [[-3, 3]] * 6, [2] * 6)
    for value in (m.mdh, m.joint_limits_rad, m.max_joint_speed_rad_s):
        assert value.dtype == np.float64 and not value.flags.writeable
    assert (m.mdh / 4)[0, 0] == 0.25
