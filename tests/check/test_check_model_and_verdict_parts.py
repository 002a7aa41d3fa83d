"""Parts of the check's model and verdict at the cases its other tests' data miss.

The other tests' covariances have equal diagonal blocks (the noise part
dominates), their calibrations either use no joint terms or bend under a
payload, and their noise is known exactly. Here: each pose's own block of
a covariance whose blocks differ, a joint scale without compliance (no
torque to compute), and a prediction raised for a noise estimated from few
rows.
"""

from __future__ import annotations

import numpy as np
import pytest

from calibrator import robots
from calibrator.check import verdict
from calibrator.check.model import Calibrated
from calibrator.model import joint_terms, parameters


def test_each_poses_block_is_its_own_three_rows_and_columns():
    n = 3
    cov = np.arange(9 * n * n, dtype=float).reshape(3 * n, 3 * n)
    blocks = verdict.pose_blocks(cov, n)
    assert blocks.shape == (n, 3, 3)
    for i in range(n):
        np.testing.assert_array_equal(blocks[i], cov[3 * i : 3 * i + 3, 3 * i : 3 * i + 3])


def _model(terms, noise_dof=None):
    arm = robots.get("ur10e")
    space = parameters.ParameterSpace(arm.mdh, np.eye(4), np.eye(4), ("theta2",))
    return Calibrated(space, np.zeros((space.size, space.size)), 0.05, terms, noise_dof)


def test_joint_scales_without_compliance_turn_the_joints_without_a_torque():
    scale = np.array([0.0, 1e-3, 0.0, 0.0, 2e-3, 0.0])
    zero = np.zeros(6)
    model = _model(joint_terms.JointTerms(scale, zero, zero, zero))
    q = np.random.default_rng(3).uniform(-1.5, 1.5, (4, 6))
    turned = model.angles(q)
    expected = joint_terms.effective(q, model.terms.vector(), None)
    np.testing.assert_allclose(turned, expected, rtol=0, atol=1e-15)
    assert np.abs(turned - q)[:, [1, 4]].min() > 0  # the scaled joints do turn further


def test_a_noise_from_few_rows_raises_the_predicted_error_by_its_bias():
    zero = np.zeros(6)
    terms = joint_terms.JointTerms(zero, zero, zero, zero)
    q = np.random.default_rng(5).uniform(-1.5, 1.5, (6, 6))
    errors = np.random.default_rng(6).normal(0.0, 0.05, (6, 3))
    few, exact = _model(terms, 4), _model(terms)
    low, known = (verdict.judge(errors, m.covariance(q), None, m.noise_dof) for m in (few, exact))
    # c4(4) = sqrt(2/4) Gamma(5/2) / Gamma(2) = 0.9400: a noise from 4 rows reads low by it.
    c4 = np.sqrt(0.5) * (0.75 * np.sqrt(np.pi))
    assert low.predicted_mm == pytest.approx(known.predicted_mm / c4, rel=1e-12)
