"""Joint intervals where two links' real surfaces keep a clearance: what capsules miss.

The cell's self-collision check skips link pairs whose capsules already
overlap with the arm stretched out at zero (a wrist fork and the flange it
folds into: one capsule cannot follow the fork). For such a pair, two links
apart (two joints between), this module sweeps one joint between them and
finds the interval around zero where the links' surfaces, given as points,
keep ``margin_mm`` apart; the other joint is taken at every angle at once:
the link it turns is replaced by its solid of revolution about that joint's
axis, so a point's distance to it is a distance in the plane of (height
along the axis, distance from the axis) (exact for the points, and no
second sweep).

Both ways are tried (sweep the first joint, turn the second freely, and
the reverse); the one keeping the larger share of its joint's range wins.
The sweep walks out from zero: no point moves farther than its lever (its
distance from the joint's axis) times the angle turned, so a distance ``d``
at one angle keeps the margin for ``(d - margin) / lever`` further, where
the next distance is taken; the walk stops where that gains less than half
of ``step_rad``. The interval it returns keeps the margin between the
sampled points at every angle, not only at samples.

Frames and units: each link's points in its own frame (a URDF moving joint's
child link, fixed children folded in), mm; angles rad, the URDF's.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from calibrator.model import frames, rotations

#: Sweep step, rad (0.5 deg): the walk stops where it would gain less than half of it.
STEP_RAD = np.radians(0.5)
#: Distances beyond the margin plus this are not looked for (the walk jumps by
#: it over the lever), mm.
LOOK_MM = 50.0
#: Side of the cubes the coarse points are picked from, mm.
COARSE_MM = 40.0


@dataclass(frozen=True)
class Link:
    """A moving link as surface points and the joint that turns it.

    Attributes
    ----------
    points : ndarray, shape (N, 3)
        Surface points in the link's frame, mm.
    to_parent : ndarray, shape (4, 4)
        The link's frame at joint angle zero in the previous moving link's
        frame (fixed joints folded in), mm.
    axis : ndarray, shape (3,)
        The joint's unit axis in the link's frame (through its origin).
    limits : tuple of float
        The joint's (lower, upper) limit, rad.
    """

    points: np.ndarray
    to_parent: np.ndarray
    axis: np.ndarray
    limits: tuple[float, float]


@dataclass(frozen=True)
class Narrowing:
    """The interval joint ``joint`` (of the pair's two) keeps the pair ``margin_mm`` apart in.

    ``joint`` is 1 (the joint turning the middle link) or 2 (the joint
    turning the far link); ``interval`` is (lower, upper), rad, within that
    joint's limits; ``zero_mm`` the distance at the interval's zero (the
    other joint at its worst).
    """

    joint: int
    interval: tuple[float, float]
    zero_mm: float


def _profile(points: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """(height along ``axis``, distance from it) of each point, shape (N, 2)."""
    h = points @ axis
    return np.column_stack([h, np.linalg.norm(points - h[:, None] * axis, axis=1)])


def _moved(points: np.ndarray, transform: np.ndarray) -> np.ndarray:
    return points @ transform[:3, :3].T + transform[:3, 3]


def _interval(
    distance: Callable[[float], float],
    limits: tuple[float, float],
    margin: float,
    lever: float,
    step: float,
) -> tuple[float, float] | None:
    """The angles around zero (within ``limits``) where ``distance`` keeps ``margin`` or more.

    ``distance`` at an angle bounds it ``lever`` times the angle turned away
    (no point moves faster): from each angle evaluated, the next is as far
    as that bound still keeps the margin, and the walk stops where it would
    gain less than half a ``step``.
    """
    lo, hi = limits
    if not lo <= 0.0 <= hi:
        return None
    lever = max(lever, 1e-9)
    first = distance(0.0)
    if (first - margin) / lever < step / 2:
        return None
    ends = []
    for sign, limit in ((-1.0, -lo), (1.0, hi)):
        clear, d = 0.0, first
        while clear < limit:
            gain = (d - margin) / lever
            if gain < step / 2:
                break
            clear = min(clear + gain, limit)
            d = distance(sign * clear)
        ends.append(sign * clear)
    return ends[0], ends[1]


def sweep(
    near: Link, middle: Link, far: Link, margin_mm: float, step_rad: float = STEP_RAD
) -> Narrowing | None:
    """The narrowing that keeps ``near`` and ``far`` ``margin_mm`` apart, if there is one.

    Parameters
    ----------
    near, middle, far : Link
        Three consecutive moving links: ``middle`` turns on joint 1 (its own),
        ``far`` on joint 2. ``near``'s ``to_parent``, ``axis`` and ``limits``
        are not used.
    margin_mm : float
        Clearance kept between the two links' points, mm.
    step_rad : float

    Returns
    -------
    Narrowing or None
        None where neither joint has an interval around zero: the two
        links come within ``margin_mm`` at zero (with the other joint free).
    """
    best: Narrowing | None = None
    bound = margin_mm + LOOK_MM
    near_in_middle = np.linalg.inv(middle.to_parent)
    middle_in_far = np.linalg.inv(far.to_parent)
    near_points = _moved(near.points, near_in_middle)  # in middle's frame
    near_profile = _profile(near_points, middle.axis)
    # Joint 1 swept, joint 2 free: near's points in far's frame against far's revolution.
    # Joint 1 keeps each of near's points' height along and distance from its axis,
    # and far's points stay within `reach` of far's origin: points of near farther
    # than that from the circle far's origin turns on never come within the bound.
    reach = float(np.max(np.linalg.norm(far.points, axis=1)))
    origin = _profile(far.to_parent[None, :3, 3], middle.axis)[0]
    kept = np.linalg.norm(near_profile - origin, axis=1) <= reach + bound
    joint_1 = _Distance(_profile(far.points, far.axis), near_points[kept], bound)
    # Either side may be taken to turn: the least lever bounds how fast the distance changes.
    lever_1 = min(float(np.max(near_profile[kept, 1], initial=0.0)), float(origin[1]) + reach)

    def distance_1(angle: float) -> float:
        to_far = middle_in_far @ frames.transform(rotations.rotvec_to_matrix(-angle * middle.axis))
        return joint_1(lambda points: _profile(_moved(points, to_far), far.axis))

    # Joint 2 swept, joint 1 free: far's points in middle's frame against near's revolution.
    joint_2 = _Distance(near_profile, far.points, bound)
    lever_2 = float(np.max(_profile(far.points, far.axis)[:, 1]))

    def distance_2(angle: float) -> float:
        to_middle = far.to_parent @ frames.transform(rotations.rotvec_to_matrix(angle * far.axis))
        return joint_2(lambda points: _profile(_moved(points, to_middle), middle.axis))

    for joint, distance, lever, limits in (
        (1, distance_1, lever_1, middle.limits),
        (2, distance_2, lever_2, far.limits),
    ):
        found = _interval(distance, limits, margin_mm, lever, step_rad)
        if found is None:
            continue
        share = (found[1] - found[0]) / (limits[1] - limits[0])
        if best is None or share > _share(best, middle, far):
            best = Narrowing(joint, found, distance(0.0))
    return best


class _Distance:
    """Least distance of moved points to a fixed point set: coarse first, all points if near.

    The coarse points (one per :data:`COARSE_MM` cube) are within ``cover``
    of every point, so their distance less ``cover`` bounds the distance of
    all from below: where that bound is enough, the points are not all moved.
    """

    def __init__(self, fixed: np.ndarray, moving: np.ndarray, bound: float) -> None:
        # Imported here: every module of calibrator.robots is imported to find the
        # arms, and a command's start should not load scipy.
        from scipy.spatial import cKDTree

        self.bound = bound
        self.tree = cKDTree(fixed)
        self.moving = moving
        if not len(moving):
            return
        cell = np.floor(moving / COARSE_MM).astype(np.int64)
        self.coarse = moving[np.unique(cell, axis=0, return_index=True)[1]]
        self.cover = float(cKDTree(self.coarse).query(moving)[0].max()) if len(moving) > 1 else 0.0

    def __call__(self, place: Callable[[np.ndarray], np.ndarray]) -> float:
        if not len(self.moving):
            return self.bound
        near = self.bound + self.cover
        coarse = min(
            float(self.tree.query(place(self.coarse), distance_upper_bound=near)[0].min()), near
        )
        if coarse - self.cover >= self.bound:
            return self.bound
        whole = self.tree.query(place(self.moving), distance_upper_bound=self.bound)[0].min()
        return min(float(whole), self.bound)


def _share(narrowing: Narrowing, middle: Link, far: Link) -> float:
    lo, hi = (middle if narrowing.joint == 1 else far).limits
    return (narrowing.interval[1] - narrowing.interval[0]) / (hi - lo)


def surface_points(
    vertices: np.ndarray, faces: np.ndarray, spacing_mm: float, seed: int = 0
) -> np.ndarray:
    """A mesh's vertices and points on its faces, about ``spacing_mm`` apart, shape (N, 3).

    Faces are sampled in proportion to their area with a seeded generator
    (the same points every run).
    """
    vertices = np.asarray(vertices, dtype=float)
    faces = np.asarray(faces, dtype=int)
    if not len(faces):
        return vertices
    corners = vertices[faces]  # (F, 3, 3)
    area = 0.5 * np.linalg.norm(
        np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1
    )
    total = float(area.sum())
    count = int(np.ceil(total / spacing_mm**2)) if total > 0 else 0
    if count == 0:
        return vertices
    rng = np.random.default_rng(seed)
    chosen = rng.choice(len(faces), size=count, p=area / total)
    u, v = rng.random(count), rng.random(count)
    flip = u + v > 1.0
    u[flip], v[flip] = 1.0 - u[flip], 1.0 - v[flip]
    c = corners[chosen]
    inside = c[:, 0] + u[:, None] * (c[:, 1] - c[:, 0]) + v[:, None] * (c[:, 2] - c[:, 0])
    return np.concatenate([vertices, inside])
