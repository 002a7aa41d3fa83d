"""Forward kinematics against independent sources, and its batching."""

from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy.spatial.transform import Rotation

from calibrator import robots
from calibrator.model import kinematics

FIXTURES = Path(__file__).parents[2] / "fixtures" / "ur"
ROS_JOINTS = ("shoulder", "upper_arm", "forearm", "wrist_1", "wrist_2", "wrist_3")


def ros_description_fk(name, q):
    """Flange pose from UR's ROS 2 description (joint origins + rotations about z).

    Independent of the DH tables: UR's own kinematics file chains each joint's
    origin (x y z, fixed-axis roll pitch yaw) and a turn about the new z axis.
    """
    k = yaml.safe_load((FIXTURES / f"{name}_default_kinematics.yaml").read_text())["kinematics"]
    t = np.eye(4)
    for joint, angle in zip(ROS_JOINTS, q, strict=True):
        e = k[joint]
        origin = np.eye(4)
        origin[:3, 3] = np.array([e["x"], e["y"], e["z"]]) * 1000.0
        origin[:3, :3] = Rotation.from_euler("xyz", [e["roll"], e["pitch"], e["yaw"]]).as_matrix()
        turn = np.eye(4)
        turn[:3, :3] = Rotation.from_euler("z", angle).as_matrix()
        t = t @ origin @ turn
    return t


@pytest.mark.parametrize("name", ["ur5e", "ur10e"])
def test_ur_models_match_the_ros_description(name):
    q = np.random.default_rng(7).uniform(-np.pi, np.pi, (20, 6))
    ours = kinematics.forward(robots.get(name).mdh, q)
    theirs = np.array([ros_description_fk(name, qq) for qq in q])
    # The ROS file rounds pi/2 to 10 digits: 1e-6 mm at 1.3 m reach.
    np.testing.assert_allclose(ours[:, :3, 3], theirs[:, :3, 3], atol=1e-6)
    np.testing.assert_allclose(ours[:, :3, :3], theirs[:, :3, :3], atol=1e-8)


@pytest.mark.parametrize(
    ("q_deg", "flange_mm"),
    [
        ((0, 0, 0, 0, 0, 0), (1355.0, 0.0, 920.0)),
        ((90, 0, 0, 0, 0, 0), (0.0, 1355.0, 920.0)),
        ((0, 90, 0, 0, 0, 0), (1090.0, 0.0, -1185.0)),
    ],
)
def test_er10l_flange_positions_worked_by_hand(q_deg, flange_mm):
    """ER10L-C10 at zero: a1 = 170 forward, a2 = 780 up (theta2 = -90 deg),
    a3 = 140 up, then d4 = 1060 and d6 = 125 forward: (1355, 0, 920).
    With q2 = +90 deg the upper arm lies along x0 and the forearm points down."""
    t = kinematics.forward(robots.get("er10l-c10").mdh, np.radians([q_deg]))
    np.testing.assert_allclose(t[0, :3, 3], flange_mm, atol=1e-9)


def test_batches_over_parameter_sets_and_poses():
    rng = np.random.default_rng(1)
    nominal = robots.get("ur10e").mdh
    swarm = nominal + rng.normal(0, 0.01, (4, 3, 6, 5))
    q = rng.uniform(-3, 3, (7, 6))
    out = kinematics.forward(swarm, q)
    assert out.shape == (4, 3, 7, 4, 4)
    for i, j in [(0, 0), (3, 2), (1, 1)]:
        np.testing.assert_allclose(out[i, j], kinematics.forward(swarm[i, j], q), atol=1e-9)
    np.testing.assert_allclose(out[..., 3, :], np.broadcast_to([0, 0, 0, 1], out[..., 3, :].shape))


def test_beta_is_a_turn_about_the_link_y_axis():
    mdh = robots.get("er10l-c10").mdh.copy()
    q = np.zeros((1, 6))
    before = kinematics.chain(mdh, q, all_frames=True)[1][0, 2]
    mdh[1, kinematics.BETA] = 0.01
    after = kinematics.chain(mdh, q, all_frames=True)[1][0, 2]
    expected = before @ np.block(
        [
            [Rotation.from_euler("y", 0.01).as_matrix(), np.zeros((3, 1))],
            [np.zeros((1, 3)), np.ones((1, 1))],
        ]
    )
    np.testing.assert_allclose(after, expected, atol=1e-12)


def test_all_frames_end_at_the_flange():
    q = np.random.default_rng(2).uniform(-3, 3, (5, 6))
    flange, link = kinematics.chain(robots.get("er10l-c10").mdh, q, all_frames=True)
    assert link.shape == (5, 7, 4, 4)
    np.testing.assert_allclose(link[:, 0], np.broadcast_to(np.eye(4), (5, 4, 4)))
    np.testing.assert_allclose(link[:, 6], flange)


def test_parallel_axes_of_the_models():
    assert kinematics.parallel_axes(robots.get("er10l-c10").mdh).tolist() == [
        False,
        True,
        False,
        False,
        False,
    ]
    assert kinematics.parallel_axes(robots.get("ur10e").mdh).tolist() == [
        False,
        True,
        True,
        False,
        False,
    ]


@pytest.mark.parametrize("name", robots.names())
def test_models_have_joint_limits_and_speeds(name):
    m = robots.get(name)
    assert m.mdh.shape == (6, 5)
    assert np.all(m.joint_limits_rad[:, 0] < m.joint_limits_rad[:, 1])
    assert np.all(m.max_joint_speed_rad_s > 0)


def test_shape_errors_name_expected_and_received():
    with pytest.raises(ValueError, match=r"\(\.\.\., 6, 5\).*\(6, 4\)"):
        kinematics.forward(np.zeros((6, 4)), np.zeros((1, 6)))
    with pytest.raises(ValueError, match=r"\(N, 6\).*\(2, 7\)"):
        kinematics.forward(np.zeros((6, 5)), np.zeros((2, 7)))
