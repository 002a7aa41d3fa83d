"""The tightest capsule along a few axes enclosing a point set: a link's collision geometry.

A capsule (segment ``p``-``q``, radius ``r``) is convex, so it encloses a
triangle mesh when it encloses the mesh's vertices (every face lies in the
convex hull of its corners), and a box when it encloses its corners. The
capsule is fitted along each candidate axis (the principal axes of the
points and of their convex hull, and the axes of the frame they are given
in: links' housings are usually drawn along their frame): its radius is that of the
smallest circle enclosing the points projected across the axis, its segment
the shortest that still holds every point within the radius. The candidate
of least volume is kept.

Frames and units: the points' own frame and unit (the URDF reader gives mm in
the link frame).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Radius added to cover rounding, relative to the points' largest coordinate
#: (1e-6 mm at a metre).
_ROUNDING = 1e-9


@dataclass(frozen=True)
class Enclosing:
    """A capsule: end points ``p``, ``q`` (3,) and ``radius``, in the points' frame and unit."""

    p: np.ndarray
    q: np.ndarray
    radius: float

    @property
    def volume(self) -> float:
        length = float(np.linalg.norm(self.q - self.p))
        return float(np.pi * self.radius**2 * (length + 4.0 / 3.0 * self.radius))


def enclose(points: np.ndarray) -> Enclosing:
    """The capsule of least volume along the candidate axes that encloses ``points`` (N, 3).

    Raises
    ------
    ValueError
        No points, or points that are not finite.
    """
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    if not len(points) or not np.all(np.isfinite(points)):
        raise ValueError("no finite points to enclose")
    hull = _hull(points)
    axes = [np.eye(3)]
    for cloud in (points, hull):  # every vertex's principal axes, and the hull's
        if len(cloud) > 1:
            axes.append(np.linalg.svd(cloud - cloud.mean(axis=0), full_matrices=False)[2])
    return min((_along(hull, a) for a in np.concatenate(axes)), key=lambda c: c.volume)


def _hull(points: np.ndarray) -> np.ndarray:
    """The convex hull's vertices: what any convex body enclosing ``points`` must enclose."""
    if len(points) < 5:
        return points
    return _hull_vertices(points)


def _hull_vertices(points: np.ndarray) -> np.ndarray:
    """``points`` on their convex hull (2-D or 3-D); all of them when flat or on a line."""
    # Imported here: every module of calibrator.robots is imported to find the
    # arms, and scipy would add its import to every command's start.
    from scipy.spatial import ConvexHull, QhullError

    try:
        return points[ConvexHull(points).vertices]
    except QhullError:
        return points


def _along(points: np.ndarray, axis: np.ndarray) -> Enclosing:
    """The capsule along ``axis`` of least radius, then least length, enclosing ``points``."""
    axis = axis / np.linalg.norm(axis)
    u = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(axis, u)
    t = points @ axis
    across = np.column_stack([points @ u, points @ v])
    centre, r = _circle(across)
    rho = np.linalg.norm(across - centre, axis=1)
    r = max(r, float(rho.max()))
    # A point (t, rho) is within r of the segment [lo, hi] of the axis when
    # lo <= t + s and hi >= t - s, s = sqrt(r^2 - rho^2): the shortest segment.
    s = np.sqrt(np.maximum(r**2 - rho**2, 0.0))
    hi, lo = float((t - s).max()), float((t + s).min())
    if lo > hi:  # one point of the axis is within r of all: a sphere
        lo = hi = (lo + hi) / 2
    foot = centre[0] * u + centre[1] * v
    # Points on the surface stay inside whatever the rounding.
    pad = _ROUNDING * (1.0 + float(np.abs(points).max()))
    return Enclosing(foot + lo * axis, foot + hi * axis, r + pad)


def _circle(points: np.ndarray) -> tuple[np.ndarray, float]:
    """The smallest circle enclosing 2-D points (N, 2): centre and radius (Welzl's, iterative)."""
    if len(points) > 3:
        points = _hull_vertices(points)
    # A fixed shuffle: the expected linear time, and the same circle every run.
    pts = points[np.random.default_rng(0).permutation(len(points))]
    tol = 1e-9 * (1.0 + float(np.abs(pts).max()))
    centre, r = pts[0], 0.0
    for i in range(1, len(pts)):
        if np.linalg.norm(pts[i] - centre) <= r + tol:
            continue
        centre, r = pts[i], 0.0
        for j in range(i):
            if np.linalg.norm(pts[j] - centre) <= r + tol:
                continue
            centre = (pts[i] + pts[j]) / 2
            r = float(np.linalg.norm(pts[i] - centre))
            for k in range(j):
                if np.linalg.norm(pts[k] - centre) > r + tol:
                    centre, r = _circumcircle(pts[i], pts[j], pts[k])
    return centre, float(r)


def _circumcircle(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, float]:
    """The circle through three points (the two farthest apart, if on a line)."""
    d = 2.0 * (a[0] * (b[1] - c[1]) + b[0] * (c[1] - a[1]) + c[0] * (a[1] - b[1]))
    if abs(d) < 1e-12 * (1.0 + float(np.abs([a, b, c]).max()) ** 2):
        p, q = max([(a, b), (a, c), (b, c)], key=lambda pq: float(np.linalg.norm(pq[0] - pq[1])))
        return (p + q) / 2, float(np.linalg.norm(p - q) / 2)
    sa, sb, sc = a @ a, b @ b, c @ c
    centre = (
        np.array(
            [
                sa * (b[1] - c[1]) + sb * (c[1] - a[1]) + sc * (a[1] - b[1]),
                sa * (c[0] - b[0]) + sb * (a[0] - c[0]) + sc * (b[0] - a[0]),
            ]
        )
        / d
    )
    return centre, float(np.linalg.norm(a - centre))
