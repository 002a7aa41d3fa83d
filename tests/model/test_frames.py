"""Rotation helpers against scipy's Rotation (an independent implementation)."""

import numpy as np
from scipy.spatial.transform import Rotation
from scipy.stats import qmc

from calibrator.halton import halton
from calibrator.model import frames, rotations


def test_rotvec_conversions_match_scipy_including_tiny_and_half_turns():
    rng = np.random.default_rng(0)
    axes = rng.normal(0, 1, (20, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    rotvecs = np.concatenate(
        [
            rng.normal(0, 1, (200, 3)),
            rng.normal(0, 1e-9, (5, 3)),
            axes * (np.pi - 1e-7),
            np.zeros((1, 3)),
        ]
    )
    matrices = rotations.rotvec_to_matrix(rotvecs)
    np.testing.assert_allclose(matrices, Rotation.from_rotvec(rotvecs).as_matrix(), atol=1e-14)
    back = rotations.matrix_to_rotvec(matrices)
    np.testing.assert_allclose(rotations.rotvec_to_matrix(back), matrices, atol=1e-12)
    below_pi = np.linalg.norm(rotvecs, axis=1) < 3.0
    np.testing.assert_allclose(back[below_pi], rotvecs[below_pi], atol=1e-12)


def test_xyz_angles_match_scipy_intrinsic_euler():
    angles = np.random.default_rng(1).uniform(-1.5, 1.5, (50, 3))
    r = rotations.rotations_xyz(angles)
    np.testing.assert_allclose(r, Rotation.from_euler("XYZ", angles).as_matrix(), atol=1e-14)
    np.testing.assert_allclose(rotations.angles_xyz(r), angles, atol=1e-12)


def test_rigid_fit_recovers_a_transform_and_inverts():
    rng = np.random.default_rng(2)
    truth = frames.transform(rotations.rotvec_to_matrix(rng.normal(0, 1, 3)), [3000.0, -200, 50])
    source = rng.normal(0, 500, (12, 3))
    target = source @ truth[:3, :3].T + truth[:3, 3]
    np.testing.assert_allclose(frames.fit_rigid(source, target), truth, atol=1e-9)
    np.testing.assert_allclose(frames.invert(truth) @ truth, np.eye(4), atol=1e-12)


def test_urdf_origins_are_rz_ry_rx_and_read_back():
    # URDF's <origin xyz rpy>: translate, then Rz(yaw) Ry(pitch) Rx(roll) (fixed axes).
    def rot(axis, a):
        c, s = np.cos(a), np.sin(a)
        i, j = [(1, 2), (2, 0), (0, 1)][axis]
        r = np.eye(3)
        r[i, i], r[i, j], r[j, i], r[j, j] = c, -s, s, c
        return r

    rng = np.random.default_rng(3)
    for _ in range(20):
        xyz, (roll, pitch, yaw) = rng.normal(0, 500, 3), rng.uniform(-1.5, 1.5, 3)
        built = frames.from_xyz_rpy([*xyz, roll, pitch, yaw])
        np.testing.assert_allclose(
            built[:3, :3], rot(2, yaw) @ rot(1, pitch) @ rot(0, roll), atol=1e-14
        )
        np.testing.assert_allclose(built[:3, 3], xyz)
        np.testing.assert_allclose(frames.xyz_rpy(built), [*xyz, roll, pitch, yaw], atol=1e-12)


def test_halton_is_scipys_sequence_and_scrambling_is_seeded():
    np.testing.assert_array_equal(
        halton(64, 48, scramble=False), qmc.Halton(d=48, scramble=False).random(64)
    )
    a = halton(20, 10, np.random.default_rng(3))
    b = halton(20, 10, np.random.default_rng(3))
    np.testing.assert_array_equal(a, b)
    assert a.min() >= 0 and a.max() < 1
    # Scrambled points stay balanced: each half of every axis holds about half of them.
    assert np.all(np.abs((a < 0.5).sum(axis=0) - 10) <= 2)
