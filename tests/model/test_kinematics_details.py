"""Kinematics details the model tables alone do not reach."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from calibrator import robots
from calibrator.model import kinematics


def test_parallel_axes_uses_a_tight_angle_tolerance():
    mdh = np.zeros((6, 5))
    # Angles between axes i and i+1: 0.1 rad, 1e-8 rad, pi - 1e-8, 1e-3 rad, 0.5 rad.
    mdh[:5, kinematics.ALPHA] = [0.1, 1e-8, np.pi - 1e-8, 1e-3, 0.5]
    assert kinematics.parallel_axes(mdh).tolist() == [False, True, True, False, False]
    # A small beta tilts the next axis out of parallel too.
    mdh[1, kinematics.BETA] = 1e-3
    assert kinematics.parallel_axes(mdh).tolist() == [False, False, True, False, False]
    assert kinematics.parallel_axes(mdh, tol=0.2).tolist() == [True, True, True, True, False]


def test_a_single_pose_may_be_given_as_one_row():
    mdh = robots.get("ur5e").mdh
    q = np.array([0.1, -0.5, 1.0, 0.3, -0.2, 0.7])
    np.testing.assert_array_equal(kinematics.forward(mdh, q), kinematics.forward(mdh, q[None]))
    assert kinematics.check_joints(q.tolist()).shape == (1, 6)
    with pytest.raises(ValueError, match=r"\(N, 6\), got \(2, 3, 6\)"):
        kinematics.check_joints(np.zeros((2, 3, 6)))
    with pytest.raises(ValueError, match=r"\(\.\.\., 6, 5\), got \(30,\)"):
        kinematics.check_mdh(np.zeros(30))


def test_link_constants_are_tz_tx_rx_ry_written_with_scipy():
    rng = np.random.default_rng(3)
    mdh = rng.normal(0, 1, (6, 5)) * [300, 1, 1, 300, 0.2]
    consts = kinematics.link_constants(mdh)
    for i in range(6):
        expected = np.eye(4)
        expected[:3, :3] = Rotation.from_euler(
            "XY", [mdh[i, kinematics.ALPHA], mdh[i, kinematics.BETA]]
        ).as_matrix()
        expected[:3, 3] = [mdh[i, kinematics.A], 0.0, mdh[i, kinematics.D]]
        np.testing.assert_allclose(consts[i], expected, atol=1e-12)


def test_joint_origins_regroup_the_chain_at_the_joints_written_with_scipy():
    # O_i = T_{i-1} Rz(theta_i) Tz(d_i), T_i = Tx(a_i) Rx(alpha_i) Ry(beta_i): the
    # elementary rotations are scipy's, and O_1 Rz(q_1) ... O_6 Rz(q_6) T_6 is the chain.
    rng = np.random.default_rng(4)
    mdh = rng.normal(0, 1, (6, 5)) * [300, 1, 1, 300, 0.2]
    origins, trailing = kinematics.joint_origins(mdh)
    before = np.eye(4)
    for i in range(6):
        head = np.eye(4)
        head[:3, :3] = Rotation.from_euler("z", mdh[i, kinematics.THETA]).as_matrix()
        head[2, 3] = mdh[i, kinematics.D]
        np.testing.assert_allclose(origins[i], before @ head, atol=1e-12)
        before = np.eye(4)
        before[:3, :3] = Rotation.from_euler(
            "XY", [mdh[i, kinematics.ALPHA], mdh[i, kinematics.BETA]]
        ).as_matrix()
        before[0, 3] = mdh[i, kinematics.A]
    np.testing.assert_allclose(trailing, before, atol=1e-12)
    q = rng.uniform(-np.pi, np.pi, 6)
    t = np.eye(4)
    for i in range(6):
        turn = np.eye(4)
        turn[:3, :3] = Rotation.from_euler("z", q[i]).as_matrix()
        t = t @ origins[i] @ turn
    np.testing.assert_allclose(t @ trailing, kinematics.chain(mdh, q)[0], atol=1e-9)
    assert kinematics.joint_origins(np.stack([mdh, mdh]))[0].shape == (2, 6, 4, 4)


def test_the_fast_path_gives_the_flange_rows_only_unless_frames_are_asked():
    rng = np.random.default_rng(4)
    mdh = robots.get("er10l-c10").mdh + rng.normal(0, 0.01, (2, 6, 5))
    q = rng.uniform(-3, 3, (5, 6))
    out = kinematics.chain_parts(
        kinematics.link_constants(mdh),
        kinematics.joint_phases(mdh[..., kinematics.THETA]),
        kinematics.joint_phases(q),
    )
    assert isinstance(out, np.ndarray) and out.shape == (2, 5, 3, 4)
    np.testing.assert_allclose(out, kinematics.chain(mdh, q)[..., :3, :], atol=1e-9)
    # joint_phases is exp(-i angle): a quarter turn is -i.
    np.testing.assert_allclose(kinematics.joint_phases([np.pi / 2, 0]), [-1j, 1], atol=1e-15)


def test_tables_and_joints_are_returned_as_floats():
    assert kinematics.check_mdh(np.zeros((6, 5), dtype=int)).dtype == np.float64
    assert kinematics.check_joints([[0, 1, 2, 3, 4, 5]]).dtype == np.float64
