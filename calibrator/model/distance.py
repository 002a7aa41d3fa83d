"""Distances between segments, points, boxes and vertical cylinders, batched.

Every function broadcasts over leading axes, so one call checks all poses,
all capsule pairs and all obstacles at once. Lengths in mm.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike


def segment_segment(p1: ArrayLike, q1: ArrayLike, p2: ArrayLike, q2: ArrayLike) -> np.ndarray:
    """Shortest distance between segments ``p1 q1`` and ``p2 q2``.

    Parameters
    ----------
    p1, q1, p2, q2 : array_like, shape (..., 3)
        End points, broadcast together.

    Returns
    -------
    ndarray, shape (...)

    Notes
    -----
    The closest points of the two lines, clamped to the segments in turn
    (the classic construction; degenerate segments are points).
    """
    p1, q1, p2, q2 = (np.asarray(v, dtype=float) for v in (p1, q1, p2, q2))
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    a = np.einsum("...i,...i->...", d1, d1)
    e = np.einsum("...i,...i->...", d2, d2)
    f = np.einsum("...i,...i->...", d2, r)
    c = np.einsum("...i,...i->...", d1, r)
    b = np.einsum("...i,...i->...", d1, d2)
    tiny = 1e-12
    denom = a * e - b * b
    # s on the first segment: from the lines' closest points, or 0 when parallel.
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(denom > tiny * np.maximum(a * e, tiny), (b * f - c * e) / denom, 0.0)
    s = np.clip(np.where(a > tiny, s, 0.0), 0.0, 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        # A point-like second segment: t = -1 forces t = 0 and s recomputed below.
        t = np.where(e > tiny, (b * s + f) / e, -1.0)
    # Clamp t, then recompute s for the clamped t.
    t_clamped = np.clip(t, 0.0, 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(t != t_clamped, np.where(a > tiny, (b * t_clamped - c) / a, 0.0), s)
    s = np.clip(s, 0.0, 1.0)
    diff = (p1 + d1 * s[..., None]) - (p2 + d2 * t_clamped[..., None])
    return np.linalg.norm(diff, axis=-1)


def point_box(points: ArrayLike, lo: ArrayLike, hi: ArrayLike) -> np.ndarray:
    """Distance of points from axis-aligned boxes (0 inside).

    Parameters
    ----------
    points : array_like, shape (..., 3)
    lo, hi : array_like, shape (..., 3)
        Box corners, broadcast with ``points``.
    """
    points, lo, hi = np.asarray(points), np.asarray(lo), np.asarray(hi)
    gap = np.maximum(np.maximum(lo - points, points - hi), 0.0)
    return np.linalg.norm(gap, axis=-1)


def point_cylinder(
    points: ArrayLike, centre_xy: ArrayLike, radius: float, z_lo: float, z_hi: float
) -> np.ndarray:
    """Distance of points from vertical solid cylinders (0 inside).

    Parameters
    ----------
    points : array_like, shape (..., 3)
    centre_xy : array_like, shape (..., 2)
    radius, z_lo, z_hi : array_like, shape (...)
    """
    points = np.asarray(points, dtype=float)
    radial = np.linalg.norm(points[..., :2] - centre_xy, axis=-1) - radius
    vertical = np.maximum(z_lo - points[..., 2], points[..., 2] - z_hi)
    return np.hypot(np.maximum(radial, 0.0), np.maximum(vertical, 0.0))


def segment_min(
    p: np.ndarray,
    q: np.ndarray,
    point_distance: Callable[[np.ndarray], np.ndarray],
    iterations: int = 40,
) -> np.ndarray:
    """Lower bound of the distance of segments ``p q`` from a convex solid.

    The distance of a point from a convex solid is convex along a segment, so
    a golden-section search finds its minimum; the result is lowered by how
    far the search bracket still leaves the minimum (the distance changes by
    at most the distance moved), so it never overstates the clearance.

    Parameters
    ----------
    p, q : ndarray, shape (..., 3)
        Segment ends, mm.
    point_distance : callable
        Maps points (..., 3) to distances (...), mm; convex in the point.
    iterations : int
        Search steps; the bracket shrinks to ``0.618**iterations`` of the segment.
    """
    p, q = np.asarray(p, dtype=float), np.asarray(q, dtype=float)
    d = q - p
    length = np.linalg.norm(d, axis=-1)
    lo, hi = np.zeros(p.shape[:-1]), np.ones(p.shape[:-1])
    ratio = (np.sqrt(5.0) - 1.0) / 2.0
    for _ in range(iterations):
        m1 = hi - ratio * (hi - lo)
        m2 = lo + ratio * (hi - lo)
        left = point_distance(p + m1[..., None] * d) <= point_distance(p + m2[..., None] * d)
        hi = np.where(left, m2, hi)
        lo = np.where(left, lo, m1)
    mid = point_distance(p + (0.5 * (lo + hi))[..., None] * d) - 0.5 * (hi - lo) * length
    return np.minimum(mid, np.minimum(point_distance(p), point_distance(q)))


def box_gap(lo1: ArrayLike, hi1: ArrayLike, lo2: ArrayLike, hi2: ArrayLike) -> np.ndarray:
    """Distance between axis-aligned boxes (0 if they overlap): a cheap lower bound, mm."""
    lo1, hi1, lo2, hi2 = (np.asarray(v) for v in (lo1, hi1, lo2, hi2))
    gap = np.maximum(np.maximum(lo2 - hi1, lo1 - hi2), 0.0)

    return np.linalg.norm(gap, axis=-1)
