"""ISO 9283 figures and test-pose placement against hand-computed values."""

import math

import numpy as np
import pytest

from calibrator import robots
from calibrator.model import frames, kinematics
from calibrator.verify import iso9283


def test_position_figures_of_a_centred_cross_match_hand_values():
    # Barycentre on the commanded point; distances 1, 1, 2, 2.
    cloud = [[[1, 0, 0], [-1, 0, 0], [0, 2, 0], [0, -2, 0]]]
    out = iso9283.position_figures(cloud, [[0, 0, 0]])
    # lbar = 1.5; S_l = sqrt(4 * 0.5^2 / 3) = sqrt(1/3)
    assert out["AP_mm"][0] == pytest.approx(0.0, abs=1e-15)
    assert out["RP_mm"][0] == pytest.approx(1.5 + 3 * math.sqrt(1 / 3), rel=1e-14)


def test_position_figures_of_an_offset_cloud_match_hand_values():
    cloud = [[[10, 0, 0], [12, 0, 0], [11, 0, 3]]]
    out = iso9283.position_figures(cloud, [[10, 0, 0]])
    # Barycentre (11, 0, 1): APx = 1, APy = 0, APz = 1, AP = sqrt(2).
    assert out["APx_mm"][0] == pytest.approx(1.0)
    assert out["APy_mm"][0] == pytest.approx(0.0, abs=1e-15)
    assert out["APz_mm"][0] == pytest.approx(1.0)
    assert out["AP_mm"][0] == pytest.approx(math.sqrt(2))
    # Distances to the barycentre: sqrt(2), sqrt(2), 2.
    lbar = (2 * math.sqrt(2) + 2) / 3
    s = math.sqrt((2 * (math.sqrt(2) - lbar) ** 2 + (2 - lbar) ** 2) / 2)
    assert out["RP_mm"][0] == pytest.approx(lbar + 3 * s, rel=1e-14)


def test_position_figures_are_per_test_pose_when_stacked():
    a = [[1, 0, 0], [-1, 0, 0], [0, 2, 0], [0, -2, 0]]
    b = [[5, 5, 5], [5, 5, 5], [5, 5, 5], [5, 5, 9]]  # barycentre (5, 5, 6)
    out = iso9283.position_figures([a, b], [[0, 0, 0], [5, 5, 5]])
    assert out["AP_mm"] == pytest.approx([0.0, 1.0])
    assert out["APz_mm"] == pytest.approx([0.0, 1.0])
    # b: distances 1, 1, 1, 3 -> lbar 1.5, S = sqrt((3 * 0.25 + 2.25) / 3) = 1
    assert out["RP_mm"] == pytest.approx([1.5 + 3 * math.sqrt(1 / 3), 4.5])


def test_position_figures_refuse_a_single_cycle():
    with pytest.raises(iso9283.Iso9283Error, match="n >= 2"):
        iso9283.position_figures([[[0, 0, 0]]], [[0, 0, 0]])


def test_orientation_figures_match_hand_values_across_plus_minus_pi():
    deg = np.pi / 180
    # a: 179 and -179 deg around a commanded 180 deg: mean deviation 0, deviations -1, +1 deg.
    # b: 1, 3 deg against 0 -> APb 2 deg; c constant.
    attained = [[[179 * deg, 1 * deg, 0.5 * deg], [-179 * deg, 3 * deg, 0.5 * deg]]]
    out = iso9283.orientation_figures(attained, [[np.pi, 0.0, 0.0]])
    assert out["APa_deg"][0] == pytest.approx(0.0, abs=1e-9)
    assert out["APb_deg"][0] == pytest.approx(2.0)
    assert out["APc_deg"][0] == pytest.approx(0.5)
    # S of (-1, +1) with n - 1 = 1: sqrt(2); RP = 3 S.
    assert out["RPa_deg"][0] == pytest.approx(3 * math.sqrt(2))
    assert out["RPb_deg"][0] == pytest.approx(3 * math.sqrt(2))
    assert out["RPc_deg"][0] == pytest.approx(0.0, abs=1e-9)


def test_p1_is_the_centre_and_p2_to_p5_sit_a_tenth_of_the_diagonal_from_corners():
    centre, side = np.array([800.0, -20.0, 300.0]), 500.0
    p = iso9283.test_positions(centre, side)
    assert p.shape == (5, 3)
    np.testing.assert_allclose(p[0], centre)
    corners = centre + 0.5 * side * np.array(
        [[1, 1, 1], [-1, 1, 1], [-1, -1, -1], [1, -1, -1]], float
    )
    diagonal = side * math.sqrt(3)  # the diagonal of the plane is a space diagonal
    for k in range(4):
        # 10 % of the diagonal from its corner, on the corner-to-centre line
        assert np.linalg.norm(p[k + 1] - corners[k]) == pytest.approx(0.1 * diagonal)
        u = (centre - corners[k]) / np.linalg.norm(centre - corners[k])
        np.testing.assert_allclose(p[k + 1], corners[k] + 0.1 * diagonal * u, atol=1e-9)


def test_test_positions_lie_on_one_diagonal_plane_holding_two_opposite_edges():
    p = iso9283.test_positions([0, 0, 0], 2.0)
    # The plane through the edges y = z = -1 and y = z = +1 is y = z.
    np.testing.assert_allclose(p[:, 1], p[:, 2], atol=1e-12)
    # Diagonally opposite test poses are symmetric about P1.
    np.testing.assert_allclose(p[1] + p[3], 2 * p[0], atol=1e-12)
    np.testing.assert_allclose(p[2] + p[4], 2 * p[0], atol=1e-12)


def test_cycle_plan_visits_p5_to_p1_each_cycle():
    q = np.arange(30, dtype=float).reshape(5, 6)
    plan, pose, cycle = iso9283.cycle_plan(q, 3)
    assert pose.tolist() == [5, 4, 3, 2, 1] * 3
    assert cycle.tolist() == [1] * 5 + [2] * 5 + [3] * 5
    np.testing.assert_array_equal(plan[0], q[4])
    np.testing.assert_array_equal(plan[-1], q[0])


def test_largest_cube_test_poses_are_reached_by_the_nominal_model():
    arm = robots.get("ur10e")
    tool = frames.transform(translation=[0, 0, 100.0])
    cube = iso9283.largest_cube(arm.mdh, arm.joint_limits_rad, tool)
    assert 300 < cube.side_mm < 1300  # a UR10e reaches 1300 mm
    q = iso9283.commanded_joints(arm.mdh, arm.joint_limits_rad, tool, cube)
    poses = kinematics.tool_poses(arm.mdh, q, tool)
    np.testing.assert_allclose(
        poses[:, :3, 3], iso9283.test_positions(cube.centre_mm, cube.side_mm), atol=1e-5
    )
    np.testing.assert_allclose(
        poses[:, :3, :3], np.broadcast_to(iso9283.TOOL_DOWN, (5, 3, 3)), atol=1e-9
    )
    # The cube fits, and one 20 % larger at the same centre does not.
    assert iso9283.cube_fits(arm.mdh, arm.joint_limits_rad, tool, cube)
    bigger = iso9283.Cube(cube.centre_mm, cube.side_mm * 1.2)
    assert not iso9283.cube_fits(arm.mdh, arm.joint_limits_rad, tool, bigger)


def test_a_cube_out_of_reach_is_refused_naming_the_pose():
    arm = robots.get("ur10e")
    tool = frames.transform(translation=[0, 0, 100.0])
    with pytest.raises(iso9283.Iso9283Error, match="out of reach"):
        iso9283.check_cube(
            arm.mdh, arm.joint_limits_rad, tool, iso9283.Cube(np.array([800.0, 0, 100]), 2500.0)
        )
