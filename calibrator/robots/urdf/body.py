"""Capsules fitted to a URDF's collision geometry: the body the cell checks."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np

from calibrator.robots import enclosing
from calibrator.robots.description import (
    Body,
    Capsule,
    DescriptionError,
)
from calibrator.robots.urdf.chain import (
    MM_PER_M,
    Chain,
    link_groups,
    numbers,
    origin_of,
)
from calibrator.robots.urdf.meshes import MAX_MESH_EXTENT_MM, MeshMissing, load_mesh

#: Margin added to every fitted capsule radius, mm.
FIT_MARGIN_MM = 10.0


#: Radius of a capsule along a link that has no collision geometry, mm.
BARE_LINK_RADIUS_MM = 60.0


def _short_of(point: np.ndarray, flange: np.ndarray, back: np.ndarray, r: float) -> np.ndarray:
    """``point`` drawn back by ``r`` along ``-back`` if it is the flange point."""
    return flange - back * r if np.linalg.norm(point - flange) < 1e-6 else point


def fit_body(
    chain: Chain,
    model_frames: np.ndarray,
    margin_mm: float = FIT_MARGIN_MM,
    link_radius_mm: np.ndarray | None = None,
) -> Body:
    """Capsules enclosing the chain's collision geometry, ``margin_mm`` larger.

    Cylinders and spheres are enclosed exactly; boxes (their corners) and
    meshes (their vertices, read with trimesh where the file is found, see
    :func:`mesh_file`) by the tightest capsule of
    :func:`calibrator.robots.enclosing.enclose`. A moving link with no
    collision geometry gets a capsule from its joint to the next one of
    :data:`BARE_LINK_RADIUS_MM` (or ``link_radius_mm``), drawn back from the
    flange by its radius. The base link's geometry
    becomes the base cylinder, standing on the mounting plane: the base
    geometry's lowest point (its vertices', corners', rims'), z = 0 at most.
    """
    frames = chain.link_frames()
    capsules: list[Capsule] = []
    base_ends: list[np.ndarray] = []  # end points of the base link's capsules, base link, mm
    base_radii: list[float] = []
    base_low: list[float] = []  # lowest point of each of the base link's collisions, base link z
    bare: list[int] = []  # links drawn along their joints, without geometry
    missing: list[str] = []  # collision meshes named but not found
    groups = link_groups(chain)
    anchors = [frames[j.child][:, 3] for j in chain.moving] + [frames[chain.tip_link][:, 3]]
    flange = anchors[6][:3]
    back = flange - anchors[4][:3]  # from the wrist towards the flange
    back = back / np.linalg.norm(back) if np.linalg.norm(back) > 1e-9 else model_frames[5][:3, 2]
    for i, names in enumerate(groups):
        to_model = np.linalg.inv(model_frames[i])
        found = False
        for name in names:
            for k, collision in enumerate(chain.root.findall(f"link[@name='{name}']/collision")):
                try:
                    fitted = _fit(chain, name, collision)
                except MeshMissing as exc:
                    missing.append(str(exc))
                    continue
                if fitted is None:
                    continue
                p, q, r, points = fitted
                at = frames[name]
                p_base, q_base = at @ np.append(p, 1.0), at @ np.append(q, 1.0)
                if i == 0:
                    base_ends += [p_base[:3], q_base[:3]]
                    base_radii.append(r)
                    # The mounting plane is where the base's own geometry ends, not
                    # where its capsule's round end does (up to a radius lower).
                    low = min(p_base[2], q_base[2]) - r
                    if points is not None:
                        low = float((points @ at[2, :3] + at[2, 3]).min())
                    base_low.append(float(low))
                    found = True
                    continue
                capsules.append(
                    Capsule(
                        f"{name}" + (f" {k + 1}" if k else ""),
                        i,
                        _point(to_model @ p_base),
                        _point(to_model @ q_base),
                        float(r + margin_mm),
                    )
                )
                found = True
        if not found and i > 0:
            # Along the link: from its joint's origin to the next joint's (or the tip).
            bare.append(i)
            r = BARE_LINK_RADIUS_MM if link_radius_mm is None else float(link_radius_mm[i - 1])
            start, end = anchors[i - 1][:3], anchors[i][:3]
            if i == 1 and not base_ends:
                # Link 1 only turns about the base's vertical axis and sits on the base:
                # from a joint origin on the mounting plane (ABB's, Yaskawa's) its capsule
                # would lie in the plane at every pose, and no pose would pass.
                start = start.copy()
                start[2] = max(start[2], _bare_base_top(model_frames))
            # A housing ends at the flange face: a cap reaching past it would swallow
            # the tool, so ends at the flange are drawn back by the radius.
            start, end = (_short_of(p, flange, back, r + margin_mm) for p in (start, end))
            capsules.append(
                Capsule(
                    f"link {i}",
                    i,
                    _point(to_model @ np.append(start, 1.0)),
                    _point(to_model @ np.append(end, 1.0)),
                    r + margin_mm,
                )
            )
    radius, top, bottom = _base_cylinder(base_ends, base_radii, base_low, model_frames, margin_mm)
    # The cell works in MDH frame 0: base cylinder heights and the shoulder in it.
    joint1 = model_frames[0]
    shift = float(joint1[2, 3]) if np.allclose(joint1[:3, :3], np.eye(3)) else 0.0
    d1_point = model_frames[1][:3, 3] if len(model_frames) > 1 else joint1[:3, 3]
    return Body(
        capsules=tuple(capsules),
        base_radius_mm=radius,
        base_top_mm=top - shift,
        mount_z_mm=bottom - shift,
        shoulder_mm=(0.0, 0.0, float(d1_point[2] - shift)),
        margin_mm=margin_mm,
        source=_body_source(chain, bare, margin_mm, missing),
        guessed=_guessed(bare, missing),
    )


def _point(homogeneous: np.ndarray) -> tuple[float, float, float]:
    """A point (4,) in homogeneous coordinates as a capsule end (mm)."""
    return float(homogeneous[0]), float(homogeneous[1]), float(homogeneous[2])


def _base_cylinder(
    ends: list[np.ndarray],
    radii: list[float],
    lows: list[float],
    model_frames: np.ndarray,
    margin_mm: float,
) -> tuple[float, float, float]:
    """The base cylinder's radius, top and bottom (base link, mm).

    A vertical cylinder about the base z axis around every base capsule
    (``ends``, ``radii``), standing on the base geometry's lowest point
    (``lows``, z = 0 at most); without base geometry, one under the
    shoulder, half its height.
    """
    if not ends:
        return BARE_LINK_RADIUS_MM * 1.5, _bare_base_top(model_frames), 0.0
    pts, r_max = np.array(ends), max(radii)
    radius = float(np.max(np.hypot(pts[:, 0], pts[:, 1])) + r_max + margin_mm)
    return radius, float(pts[:, 2].max() + r_max), float(min(0.0, min(lows)))


def _guessed(bare: list[int], missing: list[str]) -> str:
    """What :attr:`Body.guessed` says: links drawn along the joints, meshes not found; or empty."""
    if not bare and not missing:
        return ""
    why = "no collision geometry"
    if missing:
        more = f" and {len(missing) - 1} more" if len(missing) > 1 else ""
        why = f"collision meshes not found ({missing[0]}{more})"
    if not bare:
        return why
    return f"links {', '.join(map(str, bare))} are capsules drawn along the joints: {why}"


def _bare_base_top(model_frames: np.ndarray) -> float:
    """Top of the base cylinder drawn without geometry: half the shoulder height, mm."""
    return float(model_frames[0][2, 3] + model_frames[1][2, 3]) / 2


def _body_source(chain: Chain, bare: list[int], margin_mm: float, missing: list[str]) -> str:
    fitted = f"fitted to the collision geometry of {chain.path.name}"
    along = "capsules along the links between the joint origins"
    # Named but absent meshes are said, with where they were looked for: the
    # capsules drawn instead are an approximation, not the arm's housings.
    lost = (
        f" (collision meshes not found: {missing[0]}"
        + (f" and {len(missing) - 1} more" if len(missing) > 1 else "")
        + "; looked beside the URDF's package folder, in the folders above it and in "
        "ROS_PACKAGE_PATH)"
        if missing
        else " (no collision geometry found)"
    )
    if not bare:
        return f"{fitted}, +{margin_mm:g} mm"
    if len(bare) == 6:
        return f"{along}{lost}, +{margin_mm:g} mm"
    note = lost if missing else ""
    return f"{fitted}; links {', '.join(map(str, bare))}: {along}{note}; +{margin_mm:g} mm"


#: A capsule fitted to one collision element: end points and radius in the link
#: frame (mm), and points of the element whose lowest is the element's lowest
#: (its vertices or corners; None where the capsule's lowest point is the element's).
Fitted = tuple[np.ndarray, np.ndarray, float, np.ndarray | None]


def _fit(chain: Chain, link: str, collision: ET.Element) -> Fitted | None:
    """A capsule (end points in the link frame, mm, and radius) enclosing one collision."""
    where = f"{chain.path}: link {link!r} collision"
    at = origin_of(collision.find("origin"), where)
    geometry = collision.find("geometry")
    if geometry is None or not len(geometry):
        return None
    shape = geometry[0]
    if shape.tag == "sphere":
        r = _size(shape, "radius", 1, f"{where} sphere")[0]
        return at[:3, 3], at[:3, 3], float(r), None
    if shape.tag == "cylinder":
        r = _size(shape, "radius", 1, f"{where} cylinder")[0]
        half = _size(shape, "length", 1, f"{where} cylinder")[0] / 2
        # Its rims, for the lowest point (the capsule's round ends reach lower):
        # 72-gons around the circles, so no point of a rim is lower than theirs.
        angle = np.linspace(0.0, 2 * np.pi, 73)[:-1]
        out = r / np.cos(np.pi / 72)
        rim = np.column_stack([out * np.cos(angle), out * np.sin(angle), np.zeros_like(angle)])
        rims = np.concatenate([rim + [0.0, 0.0, -half], rim + [0.0, 0.0, half]])
        axis = at[:3, 2] * half
        return at[:3, 3] - axis, at[:3, 3] + axis, float(r), rims @ at[:3, :3].T + at[:3, 3]
    if shape.tag == "box":
        size = _size(shape, "size", 3, f"{where} box")
        corners = np.array(np.meshgrid(*[[-s / 2, s / 2] for s in size])).reshape(3, -1).T
        corners = corners @ at[:3, :3].T + at[:3, 3]
        capsule = enclosing.enclose(corners)
        return capsule.p, capsule.q, capsule.radius, corners
    if shape.tag == "mesh":
        return _fit_mesh(chain, shape, at, where)
    return None


def _size(shape: ET.Element, key: str, count: int, where: str) -> np.ndarray:
    """A shape's size attribute (m in the file), mm: given, positive, at most an arm's size.

    A negative or zero radius would make a capsule that encloses nothing (a
    sphere of radius -0.5 m became a -490 mm capsule every clearance check
    passed): refused, as is a size in millimetres where URDF wants metres.
    """
    if shape.get(key) is None:
        raise DescriptionError(f"{where}: no {key}")
    values = numbers(shape.get(key), count, (0.0,) * count, f"{where} {key}") * MM_PER_M
    if not np.all(values > 0):
        raise DescriptionError(f"{where}: {key} {shape.get(key)!r} must be > 0 (metres)")
    if np.any(values > MAX_MESH_EXTENT_MM):
        raise DescriptionError(
            f"{where}: {key} {shape.get(key)!r} m is no arm link's: written in millimetres? "
            "URDF lengths are metres"
        )
    return values


def _fit_mesh(chain: Chain, shape: ET.Element, at: np.ndarray, where: str) -> Fitted | None:
    loaded = load_mesh(chain, shape, at, where)
    if loaded is None:
        return None
    points = loaded[0]
    capsule = enclosing.enclose(points)
    return capsule.p, capsule.q, capsule.radius, points
