"""Observability and D-optimal design (calibrator/planning/design.py).

Each check compares with a value found another way: a determinant or
singular value of a matrix built by hand, or the greedy pick written directly.
"""

import numpy as np
import pytest

from calibrator import planning, robots
from calibrator.model import frames

UR10E = robots.get("ur10e")
TOOL = frames.transform(translation=[0.0, 0.0, 100.0])
TOOL_MM = (0.0, 0.0, 100.0)
LIMITS = np.tile([-2.0, 3.0], (6, 1))


def test_log_det_and_smallest_singular_value_of_a_known_matrix():
    blocks = np.zeros((2, 3, 4))
    blocks[0] = np.diag([1.0, 2.0, 3.0, 0.0])[:3]  # pose 0 sees parameters 0-2
    blocks[1, 0, 3] = 0.5  # pose 1 sees parameter 3
    # J^T J = diag(1, 4, 9, 0.25)
    assert planning.log_det(blocks) == pytest.approx(np.log(1 * 4 * 9 * 0.25), abs=1e-12)
    assert planning.min_singular(blocks) == pytest.approx(0.5, abs=1e-12)
    assert planning.min_singular(blocks[:, :, :3]) == pytest.approx(1.0, abs=1e-12)


def test_a_singular_design_scores_minus_infinity():
    blocks = np.zeros((2, 3, 4))
    blocks[:, :, :3] = np.eye(3)  # parameter 3 is never seen
    assert planning.log_det(blocks) == -np.inf
    assert planning.min_singular(blocks) == pytest.approx(0.0, abs=1e-12)


def test_a_design_singular_up_to_rounding_scores_minus_infinity_too():
    # Parameter 3 moves the point exactly as 0.1 p0 + 0.3 p1 would: J^T J is singular, and
    # its rounded determinant comes out tiny and negative (slogdet's sign -1).
    j = np.random.default_rng(0).normal(size=(18, 3))
    blocks = np.column_stack([j, j[:, 0] * 0.1 + j[:, 1] * 0.3]).reshape(6, 3, 4)
    assert np.linalg.slogdet(blocks.reshape(-1, 4).T @ blocks.reshape(-1, 4))[0] == -1
    assert planning.log_det(blocks) == -np.inf


def test_observability_names_the_free_parameters_and_scales_angles():
    rng = np.random.default_rng(1)
    q = rng.uniform(-np.pi, np.pi, (20, 6))
    obs = planning.observability(UR10E.mdh, q, TOOL)
    assert obs.blocks.shape == (20, 3, len(obs.names))
    # A length parameter: its column is the tool point's move per mm, an O(1) number;
    # an angle column is mm per rad divided by the 1000 mm scale, also O(1).
    norms = np.linalg.norm(obs.blocks, axis=(0, 1)) / np.sqrt(20)
    assert np.all(norms > 0.05) and np.all(norms < 3.0)


def test_the_fewest_poses_follow_the_free_parameters():
    # Three position rows per pose: ceil(free parameters / 3).
    need = planning.min_poses(UR10E.mdh)
    rng = np.random.default_rng(0)
    q = rng.uniform(-np.pi, np.pi, (64, 6))
    assert need == -(-len(planning.observability(UR10E.mdh, q).names) // 3)
    assert planning.min_poses(UR10E.mdh, tool_known=True) < need
    assert planning.min_poses(UR10E.mdh, "base") < need


def test_d_optimal_selection_picks_distinct_poses_better_than_the_first_ones():
    q = planning.sample(planning.joint_box(UR10E.joint_limits_rad, 0.1), 200, "halton", seed=3)
    blocks = planning.observability(UR10E.mdh, q, TOOL).blocks
    picks = planning.select_d_optimal(blocks, 12)
    assert len(set(picks.tolist())) == 12
    assert planning.log_det(blocks[picks]) > planning.log_det(blocks[:12]) + 1.0
    # The first pick is the single pose that sees most: the largest det(I + J J^T / ridge).
    ridge = 1e-9 * np.sum(blocks**2) / len(blocks)
    single = [np.linalg.slogdet(np.eye(3) + b @ b.T / ridge)[1] for b in blocks]
    assert picks[0] == int(np.argmax(single))
    with pytest.raises(planning.PlanError, match="201 poses asked, only 200 candidates"):
        planning.select_d_optimal(blocks, 201)


def _greedy_by_determinant(blocks, n):
    """The greedy pick written directly: add the pose that most raises log det(M)."""
    c, _, p = blocks.shape
    info = 1e-9 * np.sum(blocks * blocks) / c * np.eye(p)
    picks = []
    for _ in range(n):
        gains = [
            -np.inf if i in picks else np.linalg.slogdet(info + blocks[i].T @ blocks[i])[1]
            for i in range(c)
        ]
        best = int(np.argmax(gains))
        picks.append(best)
        info = info + blocks[best].T @ blocks[best]
    return picks


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_greedy_d_optimal_picks_are_the_direct_determinant_ones(seed):
    blocks = np.random.default_rng(seed).normal(size=(14, 3, 5))
    picks = list(planning.select_d_optimal(blocks, 8))
    assert picks == _greedy_by_determinant(blocks, 8)
    assert len(set(picks)) == 8
