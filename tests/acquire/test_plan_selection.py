"""Greedy D-optimal picks against a direct determinant; random selection; averaging defaults."""

from dataclasses import dataclass

import numpy as np
import pytest

from calibrator import plan, robots
from calibrator.acquire.averaging import TooFewReadings, measure_average


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
    picks = list(plan.select_d_optimal(blocks, 8))
    assert picks == _greedy_by_determinant(blocks, 8)
    assert len(set(picks)) == 8


def test_random_selection_takes_distinct_candidates_reproducibly():
    ur5e = robots.get("ur5e")
    pool = np.random.default_rng(3).uniform(-1.0, 1.0, (12, 6))
    cell = plan.CellConstraints(acceptance_rad=np.pi, floor_mm=None)
    kept = pool[plan.feasible(ur5e.mdh, pool, cell)]
    n = len(kept)
    first = plan.make(ur5e.mdh, ur5e.joint_limits_rad, n, cell, candidates=pool,
                      selection="random", seed=5)  # fmt: skip
    again = plan.make(ur5e.mdh, ur5e.joint_limits_rad, n, cell, candidates=pool,
                      selection="random", seed=5)  # fmt: skip
    np.testing.assert_array_equal(first, again)
    # Every feasible candidate exactly once, in a seeded order.
    assert sorted(map(tuple, first)) == sorted(map(tuple, kept))


def test_candidates_exactly_at_a_joint_limit_are_kept():
    ur5e = robots.get("ur5e")
    box = plan.joint_box(ur5e.joint_limits_rad, plan.CellConstraints().margin_rad)
    at_low, at_high = np.full(6, 0.3), np.full(6, 0.3)
    at_low[1], at_high[2] = box[1, 0], box[2, 1]
    cell = plan.CellConstraints(acceptance_rad=np.pi, floor_mm=None)
    got = plan.make(ur5e.mdh, ur5e.joint_limits_rad, 2, cell,
                    candidates=[at_low, at_high], selection="first")  # fmt: skip
    np.testing.assert_array_equal(got, [at_low, at_high])


@dataclass
class Reading:
    point_mm: np.ndarray
    accurate: bool
    rotvec_rad: np.ndarray | None = None
    device_time_us: int = 0


class ScriptedTracker:
    """Hands out prepared readings in order (the input of the averaging under test)."""

    def __init__(self, readings):
        self._readings = list(readings)

    def measure(self, timeout_s=None):
        return self._readings.pop(0)


def test_flagged_readings_are_left_out_by_default_and_half_must_remain():
    good = [Reading(np.array([1.0, 2.0, 3.0]) + 0.01 * i, True) for i in range(3)]
    flagged = [Reading(np.array([1.03, 2.03, 3.03]), False) for _ in range(2)]
    mean = measure_average(ScriptedTracker(good + flagged), 5)
    np.testing.assert_allclose(mean.mean_mm, [1.01, 2.01, 3.01])
    assert (mean.count, mean.rejected) == (3, 2)
    # Three of six accepted is the default minimum (half, rounded up); two is not.
    with pytest.raises(TooFewReadings):
        measure_average(ScriptedTracker(good[:2] + flagged * 2), 6)
    kept = measure_average(ScriptedTracker(good[:2] + flagged * 2), 6, min_count=2)
    assert kept.count == 2
    everything = measure_average(ScriptedTracker(good + flagged), 5, reject_flagged=False)
    assert everything.count == 5
