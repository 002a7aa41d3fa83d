"""Residuals, per-pose errors and Jacobian columns against values worked out aside.

The measured data are the model's own poses moved by known offsets and
turns, so the residuals must give those offsets back (model minus measured);
rotations are compared with scipy's ``Rotation``.
"""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from calibrator import robots
from calibrator.model import frames, measurement
from calibrator.model.parameters import ParameterSpace

FREE = ("a2", "theta3", "d4", "base_tx", "base_rz", "tool_x", "tool_rx")


def a_space():
    base = frames.transform(Rotation.from_rotvec([0.3, -0.2, 1.1]).as_matrix(), [2500, 300, -80])
    tool = frames.transform(Rotation.from_rotvec([0.0, 0.4, 0.0]).as_matrix(), [10, -20, 150])
    return ParameterSpace(robots.get("ur10e").mdh, base, tool, FREE)


def shifted_observations(space, x, rng, n=6):
    """Observations offset from the model by known vectors and turns."""
    q = rng.uniform(-np.pi, np.pi, (n, 6))
    pose = measurement.predict(space, x, q)
    offsets = rng.normal(0, 2.0, (n, 3))
    turns = rng.normal(0, 0.01, (n, 3))
    # measured = model - offset, and R_measured = turn^-1 . R_model, so that
    # model minus measured is +offset and R_model R_measured^T is the turn.
    measured_r = Rotation.from_rotvec(turns).inv().as_matrix() @ pose[:, :3, :3]
    obs = measurement.Observations(q, pose[:, :3, 3] - offsets, measured_r)
    return obs, offsets, turns


def test_residuals_are_model_minus_measured_then_weighted_turns():
    rng = np.random.default_rng(0)
    space = a_space()
    x = rng.normal(0, 0.01, space.size)
    obs, offsets, turns = shifted_observations(space, x, rng)
    k = 0.25  # below 1 on purpose: any k > 0 switches orientation rows on
    r = measurement.residuals(space, x, obs, k)
    assert r.shape == (36,)
    np.testing.assert_allclose(r[:18], offsets.ravel(), atol=1e-9)
    np.testing.assert_allclose(r[18:], 0.5 * turns.ravel(), atol=1e-12)


def test_orientation_rows_need_a_positive_weight():
    rng = np.random.default_rng(1)
    space = a_space()
    obs, offsets, _ = shifted_observations(space, np.zeros(space.size), rng)
    x = np.zeros(space.size)
    for r in (measurement.residuals(space, x, obs), measurement.residuals(space, x, obs, 0.0)):
        np.testing.assert_allclose(r, offsets.ravel(), atol=1e-9)
    assert measurement.uses_orientation(obs, 1e-9)
    assert not measurement.uses_orientation(obs, 0.0)
    assert not measurement.uses_orientation(measurement.Observations(obs.q, obs.points), 5.0)


def test_per_pose_errors_give_the_offsets_and_turns():
    rng = np.random.default_rng(2)
    space = a_space()
    x = rng.normal(0, 0.01, space.size)
    obs, offsets, turns = shifted_observations(space, x, rng, n=5)
    position, orientation = measurement.errors(space, x, obs)
    np.testing.assert_allclose(position, offsets, atol=1e-9)
    np.testing.assert_allclose(orientation, turns, atol=1e-12)
    points_only = measurement.Observations(obs.q, obs.points)
    position, orientation = measurement.errors(space, x, points_only)
    np.testing.assert_allclose(position, offsets, atol=1e-9)
    assert orientation is None


def test_subset_keeps_matching_rows_of_every_array():
    rng = np.random.default_rng(3)
    q, points = rng.normal(size=(5, 6)), rng.normal(size=(5, 3))
    rot = Rotation.random(5, random_state=4).as_matrix()
    obs = measurement.Observations(q, points, rot)
    assert len(obs) == 5 and obs.has_orientation
    for index in (np.array([4, 1]), np.array([False, True, False, False, True])):
        part = obs.subset(index)
        np.testing.assert_array_equal(part.q, q[index])
        np.testing.assert_array_equal(part.points, points[index])
        np.testing.assert_array_equal(part.rotations, rot[index])
    bare = measurement.Observations(q, points).subset(np.array([0, 2]))
    assert bare.rotations is None and not bare.has_orientation and len(bare) == 2
    np.testing.assert_array_equal(bare.points, points[[0, 2]])


def test_jacobian_defaults_to_position_rows_and_the_free_columns():
    rng = np.random.default_rng(5)
    space = a_space()
    x = rng.normal(0, 0.01, space.size)
    obs, _, _ = shifted_observations(space, x, rng, n=4)
    default = measurement.jacobian(space, x, obs)
    assert default.shape == (12, len(FREE))
    # Central differences of the position residuals, column by column.
    h = 1e-6
    numeric = np.column_stack(
        [
            (
                measurement.residuals(space, x + h * e, obs)
                - measurement.residuals(space, x - h * e, obs)
            )
            / (2 * h)
            for e in np.eye(space.size)
        ]
    )
    np.testing.assert_allclose(default, numeric, atol=1e-5 * np.abs(numeric).max())
    picked = measurement.jacobian(space, x, obs, 0.0, names=("d4", "a2"))
    np.testing.assert_allclose(picked, numeric[:, [FREE.index("d4"), FREE.index("a2")]], atol=1e-4)
    with_turns = measurement.jacobian(space, x, obs, 0.25, names=("tool_rx",))
    assert with_turns.shape == (24, 1)
    np.testing.assert_array_equal(with_turns[:12], 0.0)  # a tool turn leaves the point in place
    assert np.linalg.norm(with_turns[12:]) == pytest.approx(0.5 * 2.0, rel=1e-9)
