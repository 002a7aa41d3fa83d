"""Candidate poses (calibrator/planning/sampling.py): the box, seeded samples."""

import numpy as np
import pytest

from calibrator import planning, robots
from calibrator.model import frames

UR10E = robots.get("ur10e")
TOOL = frames.transform(translation=[0.0, 0.0, 100.0])
TOOL_MM = (0.0, 0.0, 100.0)
LIMITS = np.tile([-2.0, 3.0], (6, 1))


def test_the_sampling_box_is_the_limits_within_half_a_turn_less_the_margin():
    limits = np.array([[-7, 7], [-1, 2], [-3, 0.5], [-1, 1], [0, 4], [-4, 0]], float)
    box = planning.joint_box(limits, 0.25)
    expected = [
        [-np.pi + 0.25, np.pi - 0.25],
        [-0.75, 1.75],
        [-2.75, 0.25],
        [-0.75, 0.75],
        [0.25, np.pi - 0.25],
        [-np.pi + 0.25, -0.25],
    ]
    np.testing.assert_allclose(box, expected, rtol=1e-15)
    with pytest.raises(
        planning.PlanError, match="a joint margin of 57.3 deg leaves no joint range"
    ):
        planning.joint_box(limits, 1.0)  # joint 4 has 2 rad: exactly nothing left


@pytest.mark.parametrize("method", ["halton", "random"])
def test_samples_fill_the_box_and_repeat_with_the_seed(method):
    box = planning.joint_box(LIMITS, 0.1)
    q = planning.sample(box, 400, method, seed=5)
    assert q.shape == (400, 6)
    assert np.all(q >= box[:, 0]) and np.all(q <= box[:, 1])
    spread = (q.max(axis=0) - q.min(axis=0)) / (box[:, 1] - box[:, 0])
    assert np.all(spread > 0.95)  # the whole box, not a corner of it
    np.testing.assert_array_equal(q, planning.sample(box, 400, method, seed=5))
    assert not np.array_equal(q, planning.sample(box, 400, method, seed=6))


def test_halton_samples_are_more_even_than_random_ones():
    box = np.tile([0.0, 1.0], (6, 1))
    counts = [
        np.histogram(planning.sample(box, 512, m, seed=1)[:, 0], bins=8, range=(0, 1))[0]
        for m in ("halton", "random")
    ]
    assert np.ptp(counts[0]) <= 2 < np.ptp(counts[1])
    with pytest.raises(planning.PlanError, match="unknown sampling method 'sobol'; use halton or"):
        planning.sample(box, 4, "sobol")
