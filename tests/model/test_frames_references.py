"""Rigid-transform helpers against numpy's inverse and scipy's rotations."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from calibrator.model import frames, rotations


def test_a_transform_is_checked_for_shape_last_row_and_a_proper_rotation():
    good = frames.transform(Rotation.from_rotvec([0.1, 0.2, 0.3]).as_matrix(), [1, 2, 3])
    checked = frames.check_transform(good.tolist(), "base0")
    assert checked.dtype == np.float64
    np.testing.assert_array_equal(checked, good)
    with pytest.raises(ValueError, match=r"^tool0 must have shape \(4, 4\), got \(3, 4\)$"):
        frames.check_transform(good[:3], "tool0")
    with pytest.raises(ValueError, match=r"^transform must have shape"):
        frames.check_transform(np.eye(3))
    bottom = good.copy()
    bottom[3, 0] = 0.01
    with pytest.raises(ValueError, match=r"^tool0 must have a last row \[0, 0, 0, 1\]$"):
        frames.check_transform(bottom, "tool0")
    mirrored = good.copy()
    mirrored[:3, 0] *= -1
    with pytest.raises(ValueError, match=r"^tool0 rotation part is not a proper rotation$"):
        frames.check_transform(mirrored, "tool0")
    stretched = good.copy()
    stretched[:3, :3] *= 1.001
    with pytest.raises(ValueError, match="not a proper rotation"):
        frames.check_transform(stretched, "tool0")
    # Rounding in a file (1e-9) is accepted; 1e-4 is not.
    nearly = good.copy()
    nearly[:3, :3] += 1e-9
    frames.check_transform(nearly)
    off = good.copy()
    off[0, 1] += 1e-4
    with pytest.raises(ValueError, match="not a proper rotation"):
        frames.check_transform(off)


def test_transform_stacks_and_broadcasts_its_parts():
    rotations = Rotation.random(5, random_state=1).as_matrix()
    t = frames.transform(rotations, [10.0, 20.0, 30.0])
    assert t.shape == (5, 4, 4)
    np.testing.assert_array_equal(t[:, :3, :3], rotations)
    np.testing.assert_array_equal(t[:, :3, 3], np.tile([10.0, 20.0, 30.0], (5, 1)))
    np.testing.assert_array_equal(t[:, 3], np.tile([0, 0, 0, 1.0], (5, 1)))
    moved = frames.transform(translation=np.arange(6.0).reshape(2, 3))
    assert moved.shape == (2, 4, 4)
    np.testing.assert_array_equal(moved[1, :3, :3], np.eye(3))
    np.testing.assert_array_equal(moved[1, :3, 3], [3.0, 4.0, 5.0])
    np.testing.assert_array_equal(frames.transform(), np.eye(4))


def test_invert_is_the_matrix_inverse_of_stacked_transforms():
    rng = np.random.default_rng(2)
    t = frames.transform(Rotation.random(6, random_state=3).as_matrix(), rng.normal(0, 900, (6, 3)))
    np.testing.assert_allclose(frames.invert(t), np.linalg.inv(t), atol=1e-10)
    np.testing.assert_allclose(frames.invert(t[0].tolist()), np.linalg.inv(t[0]), atol=1e-10)


@pytest.mark.parametrize("axis", [[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0], [0, 1, 1], [1, 0, 1]])
@pytest.mark.parametrize("angle", [np.pi - 1e-3, 2.5, 2.0 * np.pi / 3 + 0.01])
def test_rotvec_of_large_turns_about_each_axis_matches_scipy(axis, angle):
    # Large turns make a diagonal element the largest in Shepperd's choice,
    # a different one for each axis.
    rotvec = angle * np.asarray(axis, float) / np.linalg.norm(axis)
    signs = np.array([[1, 1, 1], [-1, 1, 1], [1, -1, 1], [1, 1, -1]], float)
    vecs = rotvec * signs
    got = rotations.matrix_to_rotvec(Rotation.from_rotvec(vecs).as_matrix())
    np.testing.assert_allclose(got, vecs, atol=1e-12)


def test_rotvec_of_half_turns_has_angle_pi_and_the_axis_up_to_sign():
    axes = np.array(
        [[1, 0, 0], [0, 1, 0], [0, 0, 1], [0.6, 0.8, 0], [0, -0.6, 0.8], [0.48, 0.6, 0.64]]
    )
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    got = rotations.matrix_to_rotvec(Rotation.from_rotvec(np.pi * axes).as_matrix())
    np.testing.assert_allclose(np.linalg.norm(got, axis=1), np.pi, atol=1e-12)
    np.testing.assert_allclose(np.abs(np.sum(got * axes, axis=1)), np.pi, atol=1e-12)


def test_tiny_rotations_keep_their_relative_precision():
    rotvecs = np.array([[3e-7, -2e-7, 5e-7], [1e-13, 0, 0], [0, 0, -4e-9], [0.0, 0.0, 0.0]])
    matrices = rotations.rotvec_to_matrix(rotvecs)
    expected = Rotation.from_rotvec(rotvecs).as_matrix()
    # Off the diagonal the entries are of the size of the angle: compare them relatively.
    off = ~np.eye(3, dtype=bool)
    np.testing.assert_allclose(matrices[:, off], expected[:, off], rtol=1e-12, atol=1e-30)
    back = rotations.matrix_to_rotvec(matrices)
    np.testing.assert_allclose(back, rotvecs, rtol=1e-9, atol=1e-30)
    assert np.all(back[3] == 0)


def test_rotation_error_is_the_turn_from_measured_to_model():
    rng = np.random.default_rng(4)
    measured = Rotation.random(8, random_state=5)
    turn = rng.normal(0, 0.2, (8, 3))
    model = Rotation.from_rotvec(turn) * measured
    got = rotations.rotation_error(model.as_matrix(), measured.as_matrix())
    np.testing.assert_allclose(got, turn, atol=1e-12)


def test_rigid_fit_of_noisy_points_is_scipys_least_squares_rotation():
    rng = np.random.default_rng(6)
    truth = Rotation.from_rotvec([0.4, -1.1, 2.0])
    source = rng.normal(0, 400, (15, 3)) + [1000.0, 2000.0, -300.0]
    target = truth.apply(source) + [2500.0, 40.0, 900.0] + rng.normal(0, 0.5, (15, 3))
    fit = frames.fit_rigid(source, target)
    cs, ct = source.mean(axis=0), target.mean(axis=0)
    expected, _ = Rotation.align_vectors(target - ct, source - cs)
    np.testing.assert_allclose(fit[:3, :3], expected.as_matrix(), atol=1e-10)
    np.testing.assert_allclose(fit[:3, 3], ct - expected.apply(cs), atol=1e-7)
    np.testing.assert_array_equal(fit[3], [0, 0, 0, 1])


def test_xyz_angles_of_a_stack_and_of_a_gimbal_lock():
    angles = np.array([[0.3, -0.4, 0.5], [-2.0, 1.2, 3.0], [0.0, np.pi / 2 - 1e-3, 0.7]])
    r = Rotation.from_euler("XYZ", angles).as_matrix()
    np.testing.assert_allclose(rotations.angles_xyz(r), angles, atol=1e-9)
    np.testing.assert_allclose(rotations.rotations_xyz(angles), r, atol=1e-14)


def test_integer_transforms_are_returned_as_floats_and_the_tolerance_is_1e_6():
    checked = frames.check_transform([[0, -1, 0, 5], [1, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])
    assert checked.dtype == np.float64
    # 1e-7 of skew from rounding in a file is accepted.
    nearly = np.eye(4)
    nearly[0, 1] = 1e-7
    frames.check_transform(nearly)


def test_rotvec_of_one_matrix_and_of_a_grid_of_matrices():
    vecs = np.random.default_rng(7).normal(0, 1, (2, 3, 3))
    matrices = Rotation.from_rotvec(vecs.reshape(-1, 3)).as_matrix().reshape(2, 3, 3, 3)
    np.testing.assert_allclose(rotations.matrix_to_rotvec(matrices), vecs, atol=1e-12)
    np.testing.assert_allclose(rotations.matrix_to_rotvec(matrices[1, 2]), vecs[1, 2], atol=1e-12)
