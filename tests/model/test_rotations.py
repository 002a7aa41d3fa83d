"""Quaternions and rotation vectors in calibrator.model.rotations: they agree
with the matrix conversions, with scipy, and refuse what has no rotation."""

import numpy as np
from scipy.spatial.transform import Rotation

from calibrator.model import rotations


def test_a_quaternion_and_its_negative_give_one_rotation_vector_of_angle_at_most_pi():
    rng = np.random.default_rng(7)
    q = rng.normal(size=(50, 4)) * rng.uniform(0.1, 10.0, (50, 1))  # not normalised
    via_matrix = rotations.matrix_to_rotvec(rotations.quaternion_to_matrix(q))
    np.testing.assert_allclose(rotations.quaternion_to_rotvec(q), via_matrix, atol=1e-12)
    np.testing.assert_allclose(rotations.quaternion_to_rotvec(-q), via_matrix, atol=1e-12)
    assert np.all(np.linalg.norm(rotations.quaternion_to_rotvec(q), axis=1) <= np.pi + 1e-12)


def test_a_quaternion_with_no_rotation_gives_nan():
    bad = np.array([[0.0, 0.0, 0.0, 0.0], [np.nan, 1.0, 0.0, 0.0], [np.inf, 0.0, 0.0, 0.0]])
    assert np.isnan(rotations.quaternion_to_rotvec(bad)).all()
    good = rotations.quaternion_to_rotvec(np.array([[1.0, 0.0, 0.0, 0.0]]))
    np.testing.assert_array_equal(good, [[0.0, 0.0, 0.0]])


def test_rotation_vectors_become_scipys_quaternions_and_come_back():
    rng = np.random.default_rng(8)
    v = rng.normal(size=(50, 3)) * rng.uniform(1e-9, 1.0, (50, 1))
    q = rotations.rotvec_to_quaternion(v)
    xyzw = Rotation.from_rotvec(v).as_quat()
    np.testing.assert_allclose(q, np.column_stack([xyzw[:, 3], xyzw[:, :3]]), atol=1e-15)
    np.testing.assert_allclose(rotations.quaternion_to_rotvec(q), v, rtol=1e-9, atol=1e-15)
    np.testing.assert_array_equal(rotations.rotvec_to_quaternion(np.zeros((1, 3))), [[1, 0, 0, 0]])


def test_a_batch_converts_each_row_to_the_bit_as_that_row_alone():
    # A tracker driver converts one reading at a time, a session a batch: same numbers.
    rng = np.random.default_rng(9)
    q = rng.normal(size=(200, 4))
    v = rng.normal(size=(200, 3))
    batch_v, batch_q = rotations.quaternion_to_rotvec(q), rotations.rotvec_to_quaternion(v)
    for i in range(200):
        np.testing.assert_array_equal(rotations.quaternion_to_rotvec(q[i]), batch_v[i : i + 1])
        np.testing.assert_array_equal(rotations.rotvec_to_quaternion(v[i]), batch_q[i : i + 1])
    assert rotations.quaternion_to_rotvec(q[0]).shape == (1, 3)


def test_quaternions_scaled_identity_and_tiny_turn_convert_exactly():
    # As the emScon tracker reports a 6-DoF probe: scalar first, not always unit.
    half = np.array([np.cos(0.25), 0.0, 0.0, np.sin(0.25)])
    np.testing.assert_allclose(rotations.quaternion_to_rotvec(3.0 * half), [[0.0, 0.0, 0.5]])
    identity = rotations.quaternion_to_rotvec(np.array([1.0, 0, 0, 0]))
    np.testing.assert_array_equal(identity, np.zeros((1, 3)))
    tiny = rotations.quaternion_to_rotvec(np.array([1.0, 1e-13, 0.0, 0.0]))
    np.testing.assert_allclose(tiny, [[2e-13, 0.0, 0.0]], rtol=1e-9)
