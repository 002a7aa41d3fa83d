"""Joint limits narrowed where the meshes of links the capsule check skips would touch."""

from __future__ import annotations

import numpy as np

from calibrator.model import distance
from calibrator.robots import clearance
from calibrator.robots.description import (
    Body,
)
from calibrator.robots.urdf.body import FIT_MARGIN_MM
from calibrator.robots.urdf.chain import (
    Chain,
    link_groups,
    origin_of,
)
from calibrator.robots.urdf.meshes import MeshMissing, load_mesh

#: Surface points of collision meshes for the clearance sweep are about this far apart, mm.
SURFACE_SPACING_MM = 10.0
#: Capsules of two links closer than their radii plus this at the zero pose are
#: joined for the cell's self-collision check (its default margin), mm: their
#: meshes are swept instead (:func:`narrow_limits`).
JOINED_MM = 20.0
#: A sweep leaving a joint less than this share of its range is not applied (said instead).
MIN_SHARE = 0.5


def narrow_limits(
    chain: Chain,
    body: Body,
    model_frames: np.ndarray,
    limits: np.ndarray,
    sign: np.ndarray,
    margin_mm: float = FIT_MARGIN_MM,
) -> tuple[np.ndarray, tuple[str, ...]]:
    """Joint limits narrowed where links the capsule check skips would touch.

    Links two apart whose capsules lie within their radii plus
    :data:`JOINED_MM` at the zero pose are joined in the cell's
    self-collision check (a wrist fork and the flange): their collision
    surfaces (points about :data:`SURFACE_SPACING_MM` apart) are swept by
    :func:`calibrator.robots.clearance.sweep`, and the joint between them is
    narrowed to the interval around zero where they keep ``margin_mm``
    apart (with the other joint between at any angle). A limit is never
    widened.

    Parameters
    ----------
    chain : Chain
    body : Body
        The fitted capsules (MDH link frames, mm).
    model_frames : ndarray, shape (7, 4, 4)
        MDH frames in the base link at the zero pose, mm.
    limits : ndarray, shape (6, 2)
        Model joint limits, rad.
    sign : ndarray, shape (6,)
        Model angle = sign * URDF angle.
    margin_mm : float

    Returns
    -------
    limits : ndarray, shape (6, 2)
    notes : tuple of str
        One line per narrowed joint, and per joined pair of links with meshes
        that is not swept or not narrowed (why).
    """
    joined = _joined(body, model_frames)
    if not joined:
        return limits, ()
    out = np.array(limits, dtype=float)
    urdf_limits = [
        (lo, hi) if s > 0 else (-hi, -lo) for (lo, hi), s in zip(limits, sign, strict=True)
    ]
    frames = chain.link_frames()
    moving = chain.moving
    group_frame = [frames[chain.base_link]] + [frames[j.child] for j in moving]
    names = [chain.base_link] + [j.child for j in moving]
    surfaces = _surfaces(chain)
    notes: list[str] = []
    for a, b in joined:
        pair = f"links {names[a]} and {names[b]}"
        if surfaces[a] is None or surfaces[b] is None:
            # Capsules drawn along the links, not fitted to housings: the body's
            # source says so, and there is nothing to sweep.
            continue
        if b - a != 2 or surfaces[a + 1] is None:
            why = f"{b - a} joints apart" if b - a != 2 else f"no meshes of {names[a + 1]}"
            notes.append(f"{pair}: capsules overlap at zero, {why}: not swept")
            continue

        def link(k: int) -> clearance.Link:
            return clearance.Link(
                surfaces[k],  # type: ignore[arg-type]
                np.linalg.inv(group_frame[k - 1]) @ group_frame[k],
                moving[k - 1].axis,
                urdf_limits[k - 1],
            )

        found = clearance.sweep(link(a), link(a + 1), link(b), margin_mm)
        if found is None:
            notes.append(
                f"{pair} come within {margin_mm:g} mm of each other at zero (joints "
                f"{a + 1} and {b} at any angle): not narrowed, their clearance is not checked"
            )
            continue
        j = a + found.joint - 1  # 0-based joint narrowed
        lo, hi = found.interval if sign[j] > 0 else (-found.interval[1], -found.interval[0])
        new = (max(out[j, 0], lo), min(out[j, 1], hi))
        if new[0] <= out[j, 0] and new[1] >= out[j, 1]:
            continue
        other = b if found.joint == 1 else a + 1
        if new[1] - new[0] < MIN_SHARE * (out[j, 1] - out[j, 0]):
            # The other joint taken at every angle is what closes the gap (the MH5's
            # forearm turned about axis 4 sweeps past its lower arm): not the pair's own
            # reach, and narrowing to it would leave the arm nothing to plan with.
            notes.append(
                f"{pair}: with joint {other} at any angle their meshes keep {margin_mm:g} mm "
                f"only for joint {j + 1} in [{np.degrees(new[0]):.1f}, "
                f"{np.degrees(new[1]):.1f}] deg, under {MIN_SHARE:.0%} of its range: not "
                "narrowed, their clearance is not checked"
            )
            continue
        notes.append(
            f"joint {j + 1} limited to [{np.degrees(new[0]):.1f}, {np.degrees(new[1]):.1f}] deg "
            f"from [{np.degrees(out[j, 0]):.1f}, {np.degrees(out[j, 1]):.1f}]: beyond it the "
            f"meshes of {pair} come within {margin_mm:g} mm (joint {other} at any angle; "
            "their capsules overlap at zero, so the capsule check skips them)"
        )
        out[j] = new
    return out, tuple(notes)


def _joined(body: Body, model_frames: np.ndarray) -> list[tuple[int, int]]:
    """Moving links (1..6) two or more apart whose capsules overlap at the zero pose."""

    caps = body.capsules
    ends = np.array(
        [[(model_frames[c.link] @ np.append(e, 1.0))[:3] for e in (c.p_mm, c.q_mm)] for c in caps]
    )
    found: set[tuple[int, int]] = set()
    for x, c in enumerate(caps):
        for y, d in enumerate(caps):
            if not 1 <= c.link < d.link - 1 or d.link > 6:
                continue
            gap = distance.segment_segment(ends[x, 0], ends[x, 1], ends[y, 0], ends[y, 1])
            if float(gap) < c.radius_mm + d.radius_mm + JOINED_MM:
                found.add((c.link, d.link))
    return sorted(found)


def _surfaces(chain: Chain) -> list[np.ndarray | None]:
    """Collision mesh points of the base (0) and each moving link (1..6), in its frame, mm.

    None for a link with a collision that is not a mesh found (its surface
    would be incomplete) or with no collision.
    """
    frames = chain.link_frames()
    out: list[np.ndarray | None] = []
    for k, names in enumerate(link_groups(chain)):
        to_group = np.linalg.inv(frames[chain.base_link if k == 0 else chain.moving[k - 1].child])
        points: list[np.ndarray] = []
        complete = True
        for name in names:
            for collision in chain.root.findall(f"link[@name='{name}']/collision"):
                where = f"{chain.path}: link {name!r} collision"
                geometry = collision.find("geometry")
                if geometry is None or not len(geometry):
                    continue
                try:
                    loaded = (
                        load_mesh(
                            chain, geometry[0], origin_of(collision.find("origin"), where), where
                        )
                        if geometry[0].tag == "mesh"
                        else None
                    )
                except MeshMissing:
                    loaded = None
                if loaded is None:
                    complete = False
                    continue
                at = to_group @ frames[name]
                surface = clearance.surface_points(*loaded, SURFACE_SPACING_MM)
                points.append(surface @ at[:3, :3].T + at[:3, 3])
        out.append(np.concatenate(points) if complete and points else None)
    return out
