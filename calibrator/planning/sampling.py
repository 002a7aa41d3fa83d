"""Candidate poses: the joint box a plan samples in, seeded sampling, duplicates.

Joint angles rad; randomness from an explicit seed.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from calibrator.halton import halton
from calibrator.planning.plan import PlanError

#: Candidates closer than this on every joint are one pose (rad).
DUPLICATE_RAD = 1e-4


def joint_box(joint_limits_rad: ArrayLike, margin_rad: float) -> np.ndarray:
    """Sampling box, shape (6, 2), rad: the limits within +-pi, less ``margin_rad``."""
    limits = np.asarray(joint_limits_rad, dtype=float)
    box = np.column_stack(
        [
            np.maximum(limits[:, 0], -np.pi) + margin_rad,
            np.minimum(limits[:, 1], np.pi) - margin_rad,
        ]
    )
    if np.any(box[:, 0] >= box[:, 1]):
        raise PlanError(f"a joint margin of {np.degrees(margin_rad):.3g} deg leaves no joint range")
    return box


def sample(box: np.ndarray, n: int, method: str = "halton", seed: int = 0) -> np.ndarray:
    """``n`` joint vectors in ``box`` (6, 2): scrambled Halton or uniform random, seeded. Rad."""
    rng = np.random.default_rng(seed)
    if method == "halton":
        # The project's scrambled Halton (scipy.stats.qmc.Halton's construction) keeps
        # scipy.stats' half-second import out of measure's start-up.
        unit = halton(n, 6, rng)
    elif method == "random":
        unit = rng.random((n, 6))
    else:
        raise PlanError(f"unknown sampling method {method!r}; use halton or random")
    return box[:, 0] + unit * (box[:, 1] - box[:, 0])


def distinct(q: ArrayLike) -> np.ndarray:
    """Indices (sorted) of the first of each group of equal joint vectors of ``q`` (N, 6).

    Equal: within :data:`DUPLICATE_RAD` on every joint (a grid of that size).
    """
    q = np.asarray(q, dtype=float)
    if not len(q):
        return np.zeros(0, dtype=int)
    _, first = np.unique(np.round(q / DUPLICATE_RAD), axis=0, return_index=True)
    return np.sort(first)
