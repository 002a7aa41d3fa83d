"""Pose and motion checks of the capsule arm in its cell, batched over poses.

A pose is checked for each reason of :data:`REASONS`; a motion (the
joint-space line ``moveJ`` follows) is checked at samples at most
:data:`MOTION_STEP_RAD` of the largest joint's travel apart, with every
clearance grown by a bound on how far any capsule point can move between
two samples (so a motion passing its samples is clear all along).

Positions in the robot base frame, mm; joint angles rad.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from calibrator.cell.cellfile import Cell, CellError, obstacle_arrays
from calibrator.cell.geometry import ArmGeometry, place
from calibrator.model import distance, kinematics, singularities

#: Reasons a pose is refused, in the order checks report them.
REASONS = (
    "below mounting plane",
    "into the base",
    "self collision",
    "obstacle",
    "line of sight",
    "tracker range",
    "acceptance angle",
)
#: Reasons that also apply along a motion (no tracker needed while moving).
MOTION_REASONS = REASONS[:4]
#: Reasons ``plan`` drops a candidate pose near a singularity, where the arm
#: cannot be commanded well (a small move of the tool asks a large one of a
#: joint, and the controller's inverse kinematics flips): not a collision, so
#: ``measure`` and ``program`` still take such a pose from a user's plan.
SINGULARITY_REASONS = ("near wrist singularity", "arm stretched out", "near shoulder singularity")
#: Least angle between axes 4 and 6 (the wrist singularity: they line up), deg.
WRIST_MIN_DEG = 10.0
#: Least angle of the upper arm and forearm from parallel: stretched out or folded, deg.
ELBOW_MIN_DEG = 10.0
#: Least distance of the wrist centre from the plane through axis 1 parallel to
#: axis 2 (the shoulder singularity), mm.
SHOULDER_MIN_MM = 100.0
#: Largest joint step between samples of a motion, rad (0.5 deg).
MOTION_STEP_RAD = np.radians(0.5)


@dataclass(frozen=True)
class Checker:
    """An arm in a cell, ready to check poses and motions.

    Build with :func:`checker`. ``pairs`` are the capsule pairs checked for
    self collision: every pair except those joined at a joint (closer than
    their radii plus the margin with the arm stretched out at zero) and those
    kept apart by design (a distance no joint changes, larger than their radii).
    """

    geometry: ArmGeometry
    cell: Cell
    plane_z_mm: float
    pairs: np.ndarray  # (P, 2) capsule indices
    levers_mm: np.ndarray  # (6, K) farthest point of capsule k from joint j's axis
    pair_levers_mm: np.ndarray  # (6, P) the same for the pair's second capsule, joints between


def checker(geometry: ArmGeometry, cell: Cell) -> Checker:
    """Prepare the checks of ``geometry`` in ``cell``."""
    plane = geometry.mount_z_mm if cell.mounting_plane_z_mm is None else cell.mounting_plane_z_mm
    k = len(geometry.capsules)
    ends = place(geometry, np.zeros((1, 6)))[0]
    i, j = np.triu_indices(k, 1)
    gap = distance.segment_segment(ends[i, 0], ends[i, 1], ends[j, 0], ends[j, 1])
    joined = gap < geometry.radii[i] + geometry.radii[j] + cell.margin_mm
    # Pairs whose distance no joint changes (UR's upper arm and forearm lie in
    # parallel planes 137 mm apart) and which do not touch cannot collide: their
    # distance is a design clearance, not a margin to keep. Seen on 256 seeded poses.
    spread = np.random.default_rng(0).uniform(-np.pi, np.pi, (256, 6))
    many = place(geometry, spread)
    gaps = distance.segment_segment(many[:, i, 0], many[:, i, 1], many[:, j, 0], many[:, j, 1])
    fixed = (np.ptp(gaps, axis=0) < 1e-6 * (1.0 + gaps.max(axis=0))) & (
        gaps.min(axis=0) > geometry.radii[i] + geometry.radii[j]
    )
    pairs = np.column_stack([i, j])[~joined & ~fixed & (geometry.links[i] != geometry.links[j])]
    # Joint j turns links j..6 about an axis through frame j-1's origin: a point
    # of link k is at most sum(|d_m| + |a_m|, m = j..k) + its offset in frame k away.
    step = np.abs(geometry.mdh[:, 0]) + np.abs(geometry.mdh[:, 3])
    offset = np.array(
        [max(np.linalg.norm(c.p_mm), np.linalg.norm(c.q_mm)) for c in geometry.capsules]
    )
    links = np.minimum(geometry.links, 6)
    joint = np.arange(6)[:, None]
    reach = np.cumsum(np.concatenate([[0.0], step]))  # reach[k] - reach[j] = step[j:k].sum()
    levers = np.where(links[None, :] > joint, reach[links][None, :] - reach[:6, None] + offset, 0.0)
    # Within a pair only the joints between the two links move one relative to the other.
    first, second = links[pairs[:, 0]], links[pairs[:, 1]]
    between = (joint >= first[None, :]) & (joint < second[None, :])
    pair_levers = np.where(between, levers[:, pairs[:, 1]], 0.0)
    return Checker(geometry, cell, float(plane), pairs, levers, pair_levers)


def _ends(chk: Checker, q: np.ndarray) -> np.ndarray:
    return place(chk.geometry, q)


def _reaching_plane(geometry: ArmGeometry) -> np.ndarray:
    """Capsules a joint can move towards the mounting plane: links 2 on.

    Link 1 only turns about axis 1, the base frame's z, the plane's normal:
    its height is the arm's build, the same at every pose. Its capsule, rounder
    than the turret it encloses (an IRB 6640's reaches 123 mm below the
    plane its base stands on), would refuse every pose, not a motion.
    """
    return np.flatnonzero(geometry.links >= 2)


def collision_faults(chk: Checker, q: ArrayLike, step_rad: ArrayLike | None = None) -> np.ndarray:
    """Collision reasons (:data:`MOTION_REASONS`) per pose, shape (N, 4) bool.

    Parameters
    ----------
    chk : Checker
    q : array_like, shape (N, 6)
        Joint angles, rad.
    step_rad : array_like, shape (N, 6), optional
        Joint steps to the next sample of a motion, rad: every clearance
        grows by half the distance a capsule point can travel over that step
        (relative to the other capsule for self collision).
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    ends = _ends(chk, q)  # (N, K, 2, 3)
    geo, cell = chk.geometry, chk.cell
    radii = geo.radii
    step = np.zeros((len(q), 6)) if step_rad is None else np.abs(np.asarray(step_rad, dtype=float))
    need = radii[None, :] + cell.margin_mm + 0.5 * step @ chk.levers_mm  # (N, K)
    out = np.zeros((len(q), 4), dtype=bool)
    reaching = _reaching_plane(geo)
    low = ends[..., 2][:, reaching].min(axis=-1) - chk.plane_z_mm  # (N, K')
    out[:, 0] = np.any(low < need[:, reaching], axis=1)
    # The base: links 3 on (the first two turn about it and cannot reach it).
    # Its cylinder is bounded by the capsule on its axis (exact on the sides,
    # a rounded top a radius high that the shoulder's capsule covers anyway).
    far = np.flatnonzero(geo.links >= 3)
    axis_lo = np.array([0.0, 0.0, chk.plane_z_mm - geo.base_radius_mm])
    axis_hi = np.array([0.0, 0.0, geo.base_top_mm - geo.base_radius_mm])
    base = distance.segment_segment(ends[:, far, 0], ends[:, far, 1], axis_lo, axis_hi)
    out[:, 1] = np.any(base - geo.base_radius_mm < need[:, far], axis=1)
    a, b = chk.pairs[:, 0], chk.pairs[:, 1]
    gap = distance.segment_segment(ends[:, a, 0], ends[:, a, 1], ends[:, b, 0], ends[:, b, 1])
    pair_need = radii[a] + radii[b] + cell.margin_mm + 0.5 * step @ chk.pair_levers_mm
    out[:, 2] = np.any(gap < pair_need, axis=1)
    if cell.boxes or cell.cylinders:
        out[:, 3] = np.any(_obstacle_distance(chk, ends, float(need.max())) < need, axis=1)
    return out


def _obstacle_distance(chk: Checker, ends: np.ndarray, cutoff_mm: float = np.inf) -> np.ndarray:
    """Lower bound of each segment's distance to the nearest obstacle, shape (N, K), mm.

    ``ends`` (N, K, 2, 3). Segments whose bounding box is ``cutoff_mm`` or
    farther from an obstacle's get that box distance (a lower bound, enough
    to clear them); only the near ones get the exact search.
    """
    n, k = ends.shape[:2]
    best = np.full((n, k), np.inf)
    seg_lo, seg_hi = ends.min(axis=2), ends.max(axis=2)  # (N, K, 3)
    for lo, hi, point_distance in _solids(chk.cell):
        gap = distance.box_gap(seg_lo, seg_hi, lo, hi)
        near = gap < cutoff_mm
        if near.any():
            gap[near] = distance.segment_min(ends[near][:, 0], ends[near][:, 1], point_distance)
        best = np.minimum(best, gap)
    return best


def _solids(cell: Cell):
    """Each obstacle as (bounding box lo, hi, point distance function)."""
    obs = obstacle_arrays(cell)
    for lo, hi in zip(obs["box_lo"], obs["box_hi"], strict=True):
        yield lo, hi, lambda pts, lo=lo, hi=hi: distance.point_box(pts, lo, hi)
    for x, y, r, z0, z1 in obs["cyl"]:
        centre = np.array([x, y])
        yield (
            np.array([x - r, y - r, z0]),
            np.array([x + r, y + r, z1]),
            lambda pts, c=centre, r=r, z0=z0, z1=z1: distance.point_cylinder(pts, c, r, z0, z1),
        )


def aim_faults(chk: Checker, q: ArrayLike) -> np.ndarray:
    """Tracker range and acceptance angle per pose, shape (N, 2) bool (cheap: no capsules).

    All False when the cell has no tracker position.
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    out = np.zeros((len(q), 2), dtype=bool)
    cell = chk.cell
    if cell.tracker_at_mm is None:
        return out
    reflector, unit, dist, axis = _beam(chk, q)
    out[:, 0] = (dist < cell.min_range_mm) | (dist > cell.max_range_mm)
    out[:, 1] = np.einsum("nj,nj->n", axis, unit) < np.cos(np.radians(cell.acceptance_deg))
    return out


def _beam(chk: Checker, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Reflector (N, 3), unit vector to the tracker (N, 3), distance (N,), reflector axis (N, 3)."""
    flange = kinematics.chain(chk.geometry.mdh, q)  # (N, 4, 4)
    tool = np.asarray(chk.geometry.capsules[-1].q_mm)
    reflector = flange[:, :3, :3] @ tool + flange[:, :3, 3]
    beam = np.asarray(chk.cell.tracker_at_mm, dtype=float) - reflector
    dist = np.linalg.norm(beam, axis=1)
    return reflector, beam / np.maximum(dist, 1e-9)[:, None], dist, flange[:, :3, 2]


def sight_faults(chk: Checker, q: ArrayLike) -> np.ndarray:
    """Whether the arm or an obstacle blocks the beam to the reflector, shape (N,) bool.

    The beam runs from the tracker head to the reflector, less the tool's
    radius at its end (the reflector sits in its holder); it keeps
    ``beam_clearance_mm`` from every capsule but the tool's and from every
    obstacle (those from 200 mm in front of the head: the head's own stand).
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    cell, geo = chk.cell, chk.geometry
    if cell.tracker_at_mm is None:
        return np.zeros(len(q), dtype=bool)
    tracker = np.asarray(cell.tracker_at_mm, dtype=float)
    reflector, unit, dist, _ = _beam(chk, q)
    start = reflector + unit * np.minimum(geo.capsules[-1].radius_mm + 5.0, 0.5 * dist)[:, None]
    ends = _ends(chk, q)[:, :-1]
    gap = distance.segment_segment(start[:, None], tracker, ends[:, :, 0], ends[:, :, 1])
    blocked = np.any(gap < geo.radii[None, :-1] + cell.beam_clearance_mm, axis=1)
    if cell.boxes or cell.cylinders:
        # Obstacles from 200 mm in front of the head: the head's own stand is not in the way.
        far_end = tracker - unit * np.minimum(200.0, 0.5 * dist)[:, None]
        beam = np.stack([start, far_end], axis=1)[:, None]  # (N, 1, 2, 3)
        near = _obstacle_distance(chk, beam, cell.beam_clearance_mm)[:, 0]
        blocked |= near < cell.beam_clearance_mm
    return blocked


def pose_faults(chk: Checker, q: ArrayLike) -> np.ndarray:
    """Every reason of :data:`REASONS` per pose, shape (N, 7) bool (True: refused)."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    return np.column_stack([collision_faults(chk, q), sight_faults(chk, q), aim_faults(chk, q)])


def singularity_faults(chk: Checker, q: ArrayLike) -> np.ndarray:
    """Each reason of :data:`SINGULARITY_REASONS` per pose, shape (N, 3) bool (True: too near).

    Nearer than :data:`WRIST_MIN_DEG`, :data:`ELBOW_MIN_DEG` or
    :data:`SHOULDER_MIN_MM` by the measures of :func:`calibrator.model.singularities.margins`
    (on a UR arm the first two are ``|q5|`` and ``|q3|`` from 0 or 180 deg).
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    bounds = np.array([WRIST_MIN_DEG, ELBOW_MIN_DEG, SHOULDER_MIN_MM])
    return singularities.margins(chk.geometry.mdh, q) < bounds


def describe(chk: Checker, q: ArrayLike, reason: str) -> str:
    """What exactly fails ``reason`` at one pose ``q`` (6,): the capsules or obstacle named."""
    q = np.atleast_2d(np.asarray(q, dtype=float))[:1]
    ends = _ends(chk, q)[0]
    names, radii = chk.geometry.names, chk.geometry.radii
    margin = chk.cell.margin_mm
    if reason == REASONS[0]:
        low = ends[..., 2].min(axis=-1) - radii - chk.plane_z_mm
        low[chk.geometry.links < 2] = np.inf  # see _reaching_plane
        k = int(np.argmin(low))
        return (
            f"{names[k]} {-low[k]:.0f} mm below the mounting plane"
            if low[k] < 0
            else (f"{names[k]} within {margin:g} mm of the mounting plane")
        )
    if reason == REASONS[2]:
        a, b = chk.pairs[:, 0], chk.pairs[:, 1]
        gap = (
            distance.segment_segment(ends[a, 0], ends[a, 1], ends[b, 0], ends[b, 1])
            - radii[a]
            - radii[b]
        )
        p = int(np.argmin(gap))
        return f"{names[a[p]]} and {names[b[p]]} {gap[p]:.0f} mm apart (margin {margin:g} mm)"
    if reason == REASONS[3]:
        gaps = []
        for box in chk.cell.boxes:
            one = Cell(boxes=(box,), margin_mm=margin)
            gaps.append(
                (
                    box.name,
                    _obstacle_distance(_replace_cell(chk, one), ends[None])[0] - radii,
                )
            )
        for cyl in chk.cell.cylinders:
            one = Cell(cylinders=(cyl,), margin_mm=margin)
            gaps.append(
                (
                    cyl.name,
                    _obstacle_distance(_replace_cell(chk, one), ends[None])[0] - radii,
                )
            )
        name, gap = min(gaps, key=lambda g: g[1].min())
        k = int(np.argmin(gap))
        return (
            f"{names[k]} within {max(gap[k], 0):.0f} mm of obstacle {name!r} (margin {margin:g} mm)"
        )
    if reason == REASONS[1]:
        geo = chk.geometry
        far = np.flatnonzero(geo.links >= 3)
        axis_lo = np.array([0.0, 0.0, chk.plane_z_mm - geo.base_radius_mm])
        axis_hi = np.array([0.0, 0.0, geo.base_top_mm - geo.base_radius_mm])
        gap = distance.segment_segment(ends[far, 0], ends[far, 1], axis_lo, axis_hi)
        gap = gap - geo.base_radius_mm - radii[far]
        k = int(np.argmin(gap))
        return f"{names[far[k]]} {gap[k]:.0f} mm from the base (margin {margin:g} mm)"
    if reason == REASONS[4]:
        return "the beam from the tracker to the reflector passes through the arm or an obstacle"
    if reason == REASONS[5]:
        return (
            f"reflector outside the tracker's range "
            f"[{chk.cell.min_range_mm:g}, {chk.cell.max_range_mm:g}] mm"
        )
    return f"reflector turned more than {chk.cell.acceptance_deg:g} deg from the tracker"


def _replace_cell(chk: Checker, cell: Cell) -> Checker:
    from dataclasses import replace

    return replace(chk, cell=cell)


def motion_samples(
    qa: ArrayLike, qb: ArrayLike, step_rad: float = MOTION_STEP_RAD
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Samples of joint-space lines ``qa[i] -> qb[i]``, both ends included.

    Parameters
    ----------
    qa, qb : array_like, shape (M, 6)
        Start and end of each motion, rad.
    step_rad : float
        Largest joint step between samples.

    Returns
    -------
    q : ndarray, shape (S, 6)
        Samples of all motions, each from its start to its end.
    owner : ndarray, shape (S,)
        Motion each sample belongs to.
    joint_step : ndarray, shape (S, 6)
        Step of each joint between this sample and the next, rad.
    """
    qa, qb = np.atleast_2d(qa).astype(float), np.atleast_2d(qb).astype(float)
    delta = qb - qa
    count = np.maximum(np.ceil(np.abs(delta).max(axis=1) / step_rad).astype(int), 1)
    owner = np.repeat(np.arange(len(qa)), count + 1)
    start = np.repeat(np.cumsum(count + 1) - (count + 1), count + 1)
    u = (np.arange(owner.size) - start) / count[owner]
    q = qa[owner] + u[:, None] * delta[owner]
    return q, owner, np.abs(delta[owner]) / count[owner][:, None]


def motion_faults(
    chk: Checker, qa: ArrayLike, qb: ArrayLike, step_rad: float = MOTION_STEP_RAD
) -> np.ndarray:
    """Collision reasons along each joint-space motion ``qa[i] -> qb[i]``, shape (M, 4) bool.

    Samples include both ends; each is checked with its clearance grown by
    half the largest distance a capsule point can travel to the next sample
    (``sum_j |dq_j| * lever_j``), so the continuous motion is covered.
    """
    q, owner, step = motion_samples(qa, qb, step_rad)
    faults = np.zeros((len(np.atleast_2d(qa)), 4), dtype=bool)
    # Chunks keep memory bounded on long plans.
    for lo in range(0, len(q), 4000):
        sl = slice(lo, lo + 4000)
        bad = collision_faults(chk, q[sl], step[sl])
        np.logical_or.at(faults, owner[sl], bad)
    return faults


def check_tracker_placement(chk: Checker) -> None:
    """Refuse a tracker inside the arm's reach envelope (plus margin) or inside an obstacle.

    Raises
    ------
    CellError
    """
    cell, geo = chk.cell, chk.geometry
    if cell.tracker_at_mm is None:
        return
    at = np.asarray(cell.tracker_at_mm, dtype=float)
    if not np.all(np.isfinite(at)):
        raise CellError(f"tracker position {at.tolist()} is not finite")
    away = float(np.linalg.norm(at - np.asarray(geo.shoulder_mm)))
    envelope = geo.reach_mm + geo.radii.max() + cell.margin_mm
    if away < envelope:
        raise CellError(
            f"tracker at {', '.join(f'{v:g}' for v in at)} mm is {away:.0f} mm from the shoulder, "
            f"inside the {geo.model}'s reach envelope ({envelope:.0f} mm with the tool): "
            "the arm could hit it; place it farther away"
        )
    if at[2] < chk.plane_z_mm:
        raise CellError(
            f"tracker at z = {at[2]:g} mm is below the mounting plane ({chk.plane_z_mm:g} mm)"
        )
