"""Robot descriptions from a URDF: the serial chain from a base link to a tip link.

The chain's joint axes at the zero pose are converted exactly to an MDH table
(:func:`calibrator.model.conventions.fit_links`, the conversion the ROS kinematics
import uses), with Hayati's ``beta`` where neighbouring axes are parallel;
what the table cannot hold is kept: ``base_offset`` (MDH frame 0 in the base
link) and ``flange_offset`` (the tip link in the MDH flange frame), so that
for URDF joint angles ``q``::

    base_link2tip(q) = base_offset . A_1...A_6(to_model(q)) . flange_offset

Model angles are the URDF's, except that joint 1 turns about the base's +z
and joint 6 about the axis pointing out of the flange (so the MDH flange
frame's z points where the tool is, as on a UR): where the URDF's axis points
the other way (KUKA's A1, several A6/J6), the model angle is its negative,
recorded as the joint convention's sign. URDF angles are taken to
be the controller's (ROS-Industrial drivers pass them through; where a
controller differs, such as Fanuc's J2/J3 coupling, a description file
declares it).

Also read: position and velocity limits (``<limit>``; continuous joints get
+-2 pi), masses and centres of mass (``<inertial>`` of each moving link and
the links fixed to it), the collision geometry (boxes, cylinders, spheres;
meshes through trimesh when the file can be found) fitted with capsules at a
stated margin. Arms that are not serial 6R chains are refused in one line.

The controller's frames are ROS-Industrial's (the REP-199 draft): a link
``base`` fixed to the chain's base link is the controller's base (world)
frame, a link ``tool0`` fixed to the tip its flange with an all-zero tool
(:func:`controller_frame`). A base link named that is not above the tip but
fixed beside the chain (FANUC's ``base`` hangs off ``base_link``) is taken as
the controller's base frame, the chain starting at the link it is fixed to.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from calibrator.inputs import grammar, textfile
from calibrator.inputs.errors import StrictError
from calibrator.model import conventions, distance, kinematics
from calibrator.model.frames import from_xyz_rpy
from calibrator.robots import clearance, enclosing
from calibrator.robots.description import (
    Body,
    Capsule,
    DescriptionError,
    JointConvention,
    RobotDescription,
)

#: Refuse URDF files larger than this (a 6-axis arm's is tens of kilobytes).
MAX_BYTES = 16 * 2**20
_M = 1000.0
#: A joint origin farther than this from its parent (mm) is no arm's: lengths written in
#: millimetres where URDF wants metres (a 400 mm link read as 400 m).
MAX_JOINT_OFFSET_MM = 10_000.0
#: A joint limit beyond this (rad, two turns) was written in degrees, where URDF wants radians.
MAX_LIMIT_RAD = 4 * np.pi
#: A joint speed above this (rad/s) was written in deg/s (the fastest shipped wrist: 25 rad/s).
MAX_SPEED_RAD_S = 60.0
#: A collision mesh wider than this once scaled (mm) is no arm link's: a mesh in
#: millimetres without its scale, or a scale that would make the clearance
#: sweep sample its surface by the billion (``scale="300"``: gigabytes).
MAX_MESH_EXTENT_MM = 10_000.0
#: The largest collision mesh surface (m^2) the clearance sweep samples, every
#: :data:`SURFACE_SPACING_MM` (50 m^2: half a million points; a 2 x 2 x 3 m link has 32).
#: Faces folded on one another within the extent could otherwise ask for billions.
MAX_MESH_AREA_M2 = 50.0
#: The largest collision mesh file read (bytes).
MAX_MESH_BYTES = 64 * 2**20
#: Base links tried when none is given, in order.
BASE_LINKS = ("base_link",)
#: Tip links tried when none is given, in order.
TIP_LINKS = ("tool0", "flange")
#: Margin added to every fitted capsule radius, mm.
FIT_MARGIN_MM = 10.0
#: Neighbouring axes closer than this (rad) get Hayati's ``beta``, as the ROS
#: kinematics import does: a slightly tilted axis (a measured or perturbed
#: URDF) would otherwise put the common normal metres away (a huge ``d``).
NEAR_PARALLEL_RAD = 0.1
#: Surface points of collision meshes for the clearance sweep are about this far apart, mm.
SURFACE_SPACING_MM = 10.0
#: Capsules of two links closer than their radii plus this at the zero pose are
#: joined for the cell's self-collision check (its default margin), mm: their
#: meshes are swept instead (:func:`narrow_limits`).
JOINED_MM = 20.0
#: A sweep leaving a joint less than this share of its range is not applied (said instead).
MIN_SHARE = 0.5
#: Radius of a capsule along a link that has no collision geometry, mm.
BARE_LINK_RADIUS_MM = 60.0
_MOVING = ("revolute", "continuous")


@dataclass(frozen=True)
class Joint:
    """One joint of the chain, as the URDF gives it (mm, rad)."""

    name: str
    kind: str
    parent: str
    child: str
    origin: np.ndarray  # (4, 4) child joint frame in the parent link frame, mm
    axis: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0]))
    lower: float | None = None
    upper: float | None = None
    velocity: float | None = None


@dataclass(frozen=True)
class Chain:
    """The serial chain from ``base_link`` to ``tip_link`` of a URDF file."""

    path: Path
    robot: str
    base_link: str
    tip_link: str
    joints: tuple[Joint, ...]
    root: ET.Element
    #: A base link named that is not above the tip but fixed to the chain's base
    #: (FANUC's ``base``, a sibling of ``base_link``): the controller's base frame.
    world_link: str | None = None

    @property
    def moving(self) -> tuple[Joint, ...]:
        return tuple(j for j in self.joints if j.kind in _MOVING)

    def link_frames(self) -> dict[str, np.ndarray]:
        """Every chain link's frame in the base link at the zero pose, mm."""
        frames = {self.base_link: np.eye(4)}
        for joint in self.joints:
            frames[joint.child] = frames[joint.parent] @ joint.origin
        return frames


def _fail(path: Path | str, what: str) -> DescriptionError:
    return DescriptionError(f"{path}: {what}")


def _numbers(text: str | None, count: int, default: tuple[float, ...], where: str) -> np.ndarray:
    if text is None:
        return np.array(default, dtype=float)
    parts = text.split()
    try:
        values = np.array([grammar.parse_number(p, where) for p in parts], dtype=float)
    except StrictError:
        raise DescriptionError(f"{where}: {text!r} is not {count} numbers") from None
    if values.shape != (count,):
        raise DescriptionError(f"{where}: {text!r} is not {count} numbers")
    return values


def origin_of(element: ET.Element | None, where: str) -> np.ndarray:
    """The transform of an ``<origin xyz rpy>`` element (mm), identity if absent."""
    if element is None:
        return np.eye(4)
    xyz = _numbers(element.get("xyz"), 3, (0.0, 0.0, 0.0), f"{where} origin xyz")
    rpy = _numbers(element.get("rpy"), 3, (0.0, 0.0, 0.0), f"{where} origin rpy")
    if np.any(np.abs(xyz) > MAX_JOINT_OFFSET_MM / _M):  # before scaling: 1e308 m overflows
        raise DescriptionError(
            f"{where}: origin xyz {element.get('xyz')!r:.60} is beyond "
            f"{MAX_JOINT_OFFSET_MM / _M:g} m, no arm's: written in millimetres? "
            "URDF lengths are metres"
        )
    if np.any(np.abs(rpy) > MAX_LIMIT_RAD):
        raise DescriptionError(
            f"{where}: origin rpy {element.get('rpy')!r:.60} is more than two turns: "
            "written in degrees? URDF angles are radians"
        )
    return from_xyz_rpy(np.concatenate([xyz * _M, rpy]))


def read_chain(
    path: str | os.PathLike[str], base_link: str | None = None, tip_link: str | None = None
) -> Chain:
    """The serial chain of a URDF file between two links.

    Parameters
    ----------
    path : str or Path
    base_link, tip_link : str, optional
        Defaults: :data:`BASE_LINKS`, then the first of :data:`TIP_LINKS` present.

    Raises
    ------
    DescriptionError
        Unreadable, not a URDF, a link missing, or links not on one chain.
    """
    path = Path(path)
    try:
        text = textfile.read_text(path, MAX_BYTES, "a URDF file")
    except StrictError as exc:
        raise DescriptionError(str(exc)) from None
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise _fail(path, f"not a URDF file (XML error: {exc})") from None
    if root.tag != "robot":
        raise _fail(path, f"not a URDF file (the root element is <{root.tag}>, not <robot>)")
    links = {e.get("name") for e in root.findall("link")}
    by_child: dict[str, ET.Element] = {}
    for element in root.findall("joint"):
        child = element.find("child")
        if child is not None and child.get("link"):
            by_child[str(child.get("link"))] = element

    def pick(given: str | None, defaults: tuple[str, ...], what: str) -> str:
        if given is not None:
            if not isinstance(given, str):  # a description file's tip_link: [a, b]
                raise _fail(path, f"the {what} link must be one link's name, got {given!r:.60}")
            if given not in links:
                raise _fail(
                    path, f"no {what} link {given!r} (links: {', '.join(sorted(map(str, links)))})"
                )
            return given
        for name in defaults:
            if name in links:
                return name
        raise _fail(path, f"no {what} link ({' or '.join(defaults)}); name it with --{what}-link")

    base = pick(base_link, BASE_LINKS, "base")
    tip = pick(tip_link, TIP_LINKS, "tip")
    # Every joint from the tip up to the root of the tree.
    elements: list[ET.Element] = []
    above = [tip]
    while above[-1] != base and above[-1] in by_child:
        element = by_child[above[-1]]
        elements.append(element)
        parent = element.find("parent")
        above.append(str(parent.get("link")) if parent is not None else "")
        if len(elements) > len(by_child):
            raise _fail(path, "the joints form a loop")
    world = None
    if above[-1] != base:
        # Not above the tip: a frame fixed to the chain's base (FANUC's ``base``
        # hangs off base_link) is the controller's base frame, the chain starts
        # at the link it is fixed to.
        moving = [i for i, e in enumerate(elements) if e.get("type") in _MOVING]
        below_first = above[moving[-1] + 1 :] if moving else []
        attached = _fixed_to(root, base, set(below_first))
        if attached is None:
            raise _fail(path, f"link {tip!r} is not below {base!r} on one chain")
        world, base = base, attached[0]
        elements = elements[: above.index(base)]
    joints = tuple(_joint(path, e) for e in reversed(elements))
    return Chain(path, str(root.get("name") or path.stem), base, tip, joints, root, world)


def _fixed_to(root: ET.Element, link: str, targets: set[str]) -> tuple[str, np.ndarray] | None:
    """The first of ``targets`` that ``link`` is fixed to, and ``link``'s pose in it (mm).

    Walks the URDF's fixed joints both ways (parent to child and back) from
    ``link``; None when no target is reached through fixed joints alone.
    """
    edges: dict[str, list[tuple[str, np.ndarray]]] = {}
    for element in root.findall("joint"):
        if element.get("type") != "fixed":
            continue
        parent, child = element.find("parent"), element.find("child")
        if parent is None or child is None:
            continue
        a, b = str(parent.get("link")), str(child.get("link"))
        origin = origin_of(element.find("origin"), f"joint {element.get('name')!r}")
        edges.setdefault(a, []).append((b, origin))
        edges.setdefault(b, []).append((a, np.linalg.inv(origin)))
    # Breadth first: pose[x] is x's frame in ``link``'s.
    pose = {link: np.eye(4)}
    queue = [link]
    while queue:
        here = queue.pop(0)
        if here in targets:
            return here, np.linalg.inv(pose[here])
        for there, step in edges.get(here, []):
            if there not in pose:
                pose[there] = pose[here] @ step
                queue.append(there)
    return None


#: Links ROS-Industrial's support packages name after the controller's frames
#: (the REP-199 draft, "Coordinate Frames for Serial Industrial Manipulators"):
#: ``base`` is the controller's base (world) frame, ``tool0`` its flange with an
#: all-zero tool, so that tool0 looked up in base is the pose the pendant shows.
REP199_BASE = "base"
REP199_FLANGE = "tool0"


def controller_frame(chain: Chain, link: str, end: str) -> np.ndarray | None:
    """A link fixed to the chain's base (``end="base"``) or flange (``"flange"``), or None.

    Returns its pose (4, 4, mm) in the chain's base link, or in its tip link,
    found through fixed joints only; None when ``link`` is not in the file or
    not fixed to that end.
    """
    groups = _groups(chain)
    group = groups[0] if end == "base" else groups[-1]
    if link not in {e.get("name") for e in chain.root.findall("link")}:
        return None
    found = _fixed_to(chain.root, link, set(group))
    if found is None:
        return None
    anchor = chain.base_link if end == "base" else chain.tip_link
    if link == anchor:
        return np.eye(4)  # exactly: the chain's own end
    frames = chain.link_frames()
    return np.linalg.inv(frames[anchor]) @ frames[found[0]] @ found[1]


def _joint(path: Path, element: ET.Element) -> Joint:
    name = str(element.get("name"))
    kind = str(element.get("type"))
    where = f"{path}: joint {name!r}"
    if element.find("mimic") is not None:
        raise DescriptionError(f"{where} mimics another joint: coupled chains are not supported")
    if kind not in (*_MOVING, "fixed"):
        what = {"prismatic": "a linear axis or track", "planar": "a planar joint"}.get(
            kind, f"a {kind} joint"
        )
        raise DescriptionError(
            f"{where} is {kind} ({what}): only serial 6-axis arms of revolute joints are supported"
        )
    parent, child = element.find("parent"), element.find("child")
    axis = _numbers(
        element.find("axis").get("xyz") if element.find("axis") is not None else None,  # type: ignore[union-attr]
        3,
        (1.0, 0.0, 0.0),
        f"{where} axis",
    )
    if kind in _MOVING and not np.linalg.norm(axis) > 1e-9:
        raise DescriptionError(f"{where}: its axis is zero")
    limit = element.find("limit")
    lower = upper = velocity = None
    if limit is not None:
        for key in ("lower", "upper", "velocity"):
            if limit.get(key) is not None:
                value = _numbers(limit.get(key), 1, (0.0,), f"{where} limit {key}")[0]
                if key == "lower":
                    lower = value
                elif key == "upper":
                    upper = value
                else:
                    velocity = value
    origin = origin_of(element.find("origin"), where)
    if np.linalg.norm(origin[:3, 3]) > MAX_JOINT_OFFSET_MM:
        raise DescriptionError(
            f"{where}: its origin is {np.linalg.norm(origin[:3, 3]) / _M:.4g} m from its parent, "
            "no arm's: written in millimetres? URDF lengths are metres"
        )
    return Joint(
        name=name,
        kind=kind,
        parent=str(parent.get("link")) if parent is not None else "",
        child=str(child.get("link")) if child is not None else "",
        origin=origin,
        axis=axis / max(float(np.linalg.norm(axis)), 1e-300),
        lower=lower,
        upper=upper,
        velocity=velocity,
    )


@dataclass(frozen=True)
class Kinematics:
    """A chain's MDH table and what it cannot hold (see the module docstring)."""

    mdh: np.ndarray
    base_offset: np.ndarray
    flange_offset: np.ndarray
    sign: np.ndarray  # (6,) model angle = sign * URDF angle


def joint_axes(chain: Chain) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each moving joint's frame (z = its axis as turned) and the tip, at the zero pose.

    Returns
    -------
    joints : ndarray, shape (6, 4, 4)
        Base-link frame of each joint, z along the axis the model turns about (mm).
    tip : ndarray, shape (4, 4)
    sign : ndarray, shape (6,)
    """
    moving = chain.moving
    if len(moving) != 6:
        extra = " (a 7-axis arm or an arm on a track is not supported)" if len(moving) > 6 else ""
        raise _fail(
            chain.path,
            f"{len(moving)} moving joints between {chain.base_link!r} and {chain.tip_link!r}: "
            f"only serial 6-axis arms are supported{extra}",
        )
    frames = chain.link_frames()
    out = np.empty((6, 4, 4))
    sign = np.ones(6)
    tip = frames[chain.tip_link]
    # Axis 6 out of the flange, so the MDH flange frame's z points away from the wrist
    # (where the tool is): from joint 5 towards the tip, else the tip frame's z.
    outward = tip[:3, 3] - frames[moving[4].child][:3, 3]
    if np.linalg.norm(outward) < 1e-6:
        outward = tip[:3, 2]
    for i, joint in enumerate(moving):
        # The joint turns the child frame about the axis given in that (child) frame.
        at = frames[joint.child]
        z = at[:3, :3] @ joint.axis
        if i == 0 and z[2] < -1e-12:
            sign[0] = -1.0  # joint 1 about the base's +z: the model angle is the URDF's negative
        if i == 5 and z @ outward < -1e-12:
            sign[5] = -1.0  # joint 6 about the outward axis: the model angle is the negative
        out[i] = _frame_on(at[:3, 3], sign[i] * z)
    return out, tip, sign


def _frame_on(origin: np.ndarray, z: np.ndarray) -> np.ndarray:
    z = z / np.linalg.norm(z)
    x = np.cross([0.0, 1.0, 0.0], z) if abs(z[1]) < 0.9 else np.cross([1.0, 0.0, 0.0], z)
    x /= np.linalg.norm(x)
    out = np.eye(4)
    out[:3, :3] = np.column_stack([x, np.cross(z, x), z])
    out[:3, 3] = origin
    return out


def kinematics_of(chain: Chain) -> Kinematics:
    """The chain's MDH table, exactly (see the module docstring)."""
    joints, tip, sign = joint_axes(chain)
    z = joints[:, :3, 2]
    parallel = np.linalg.norm(np.cross(z[:-1], z[1:]), axis=1) < np.sin(NEAR_PARALLEL_RAD)
    flange = _flange_on_axis(tip, z[5])
    mdh, base2frame0, residual = conventions.fit_links(joints, flange, np.zeros((6, 5)), parallel)
    if not (np.all(np.isfinite(mdh)) and np.all(np.isfinite(residual))):
        raise _fail(chain.path, "the joint axes do not describe a 6R arm")
    return Kinematics(mdh, base2frame0, residual @ np.linalg.inv(flange) @ tip, sign)


def _flange_on_axis(tip: np.ndarray, z: np.ndarray) -> np.ndarray:
    """The tip frame turned so its z is axis 6 (``z``), x as near the tip's as it goes.

    ``theta_6`` is read off the flange frame's x axis about z: from a tip
    frame whose z is not axis 6 (a ``tool0`` with x out of the flange, a
    ``link_6`` frame) it would depend on how a hair's tilt resolves, and a
    slightly perturbed copy of the arm would get a flange frame turned by 90
    or 180 degrees. The tip's x, or its y where x lies within 30 degrees of
    the axis, projected across the axis, is stable. A tip already on the axis
    is returned as it is.
    """
    z = z / np.linalg.norm(z)
    if np.linalg.norm(np.cross(tip[:3, 2], z)) < 1e-9:
        return tip
    x = tip[:3, 0] if abs(tip[:3, 0] @ z) < np.cos(np.radians(30.0)) else tip[:3, 1]
    x = x - z * (x @ z)
    x /= np.linalg.norm(x)
    out = tip.copy()
    out[:3, :3] = np.column_stack([x, np.cross(z, x), z])
    return out


def _limits(chain: Chain, sign: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    limits = np.empty((6, 2))
    speeds = np.empty(6)
    for i, joint in enumerate(chain.moving):
        if joint.kind == "continuous" and (joint.lower is None or joint.upper is None):
            lo, hi = -2 * np.pi, 2 * np.pi
        elif joint.lower is None or joint.upper is None:
            raise _fail(chain.path, f"joint {joint.name!r} has no lower and upper limit")
        else:
            lo, hi = joint.lower, joint.upper
        if not lo < hi:
            raise _fail(chain.path, f"joint {joint.name!r}: lower limit {lo} is not below {hi}")
        if max(abs(lo), abs(hi)) > MAX_LIMIT_RAD:
            raise _fail(
                chain.path,
                f"joint {joint.name!r}: limits [{lo:g}, {hi:g}] are more than two turns: "
                "written in degrees? URDF limits are radians",
            )
        limits[i] = (lo, hi) if sign[i] > 0 else (-hi, -lo)
        if joint.velocity is None or not joint.velocity > 0:
            raise _fail(chain.path, f"joint {joint.name!r} has no velocity limit > 0")
        if joint.velocity > MAX_SPEED_RAD_S:
            raise _fail(
                chain.path,
                f"joint {joint.name!r}: velocity {joint.velocity:g} rad/s is no arm's: "
                "written in deg/s? URDF velocities are rad/s",
            )
        speeds[i] = joint.velocity
    return limits, speeds


def _groups(chain: Chain) -> list[list[str]]:
    """Link names riding on the base (0) and on each moving joint (1..6)."""
    groups: list[list[str]] = [[chain.base_link]]
    for joint in chain.joints:
        if joint.kind in _MOVING:
            groups.append([])
        groups[-1].append(joint.child)
    return groups


def _masses(chain: Chain, model_frames: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    frames = chain.link_frames()
    mass = np.zeros(6)
    com = np.zeros((6, 3))
    for i, names in enumerate(_groups(chain)[1:]):
        total, moment = 0.0, np.zeros(3)
        for name in names:
            inertial = chain.root.find(f"link[@name='{name}']/inertial")
            if inertial is None or inertial.find("mass") is None:
                continue
            where = f"{chain.path}: link {name!r} inertial"
            m = _numbers(inertial.find("mass").get("value"), 1, (0.0,), where)[0]  # type: ignore[union-attr]
            if m < 0:
                raise _fail(chain.path, f"link {name!r} has a negative mass")
            point = frames[name] @ origin_of(inertial.find("origin"), where)[:, 3]
            total += m
            moment += m * point[:3]
        if total > 0:
            mass[i] = total
            local = np.linalg.inv(model_frames[i + 1]) @ np.append(moment / total, 1.0)
            com[i] = local[:3]
    return (mass, com) if mass.any() else None


def describe(
    path: str | Path,
    base_link: str | None = None,
    tip_link: str | None = None,
    name: str | None = None,
    margin_mm: float = FIT_MARGIN_MM,
    link_radius_mm: np.ndarray | None = None,
) -> RobotDescription:
    """A robot description of the chain of a URDF file.

    Parameters
    ----------
    path : str or Path
    base_link, tip_link : str, optional
        See :func:`read_chain`.
    name : str, optional
        The description's name [default: the path as given].
    margin_mm, link_radius_mm
        See :func:`fit_body`.

    Raises
    ------
    DescriptionError
        One line naming what is wrong or unsupported.
    """
    chain = read_chain(path, base_link, tip_link)
    kin = kinematics_of(chain)
    limits, speeds = _limits(chain, kin.sign)
    # Base link -> MDH frame i at the zero pose.
    model_frames = kin.base_offset @ kinematics.chain(kin.mdh, np.zeros(6), all_frames=True)[1][0]
    masses = _masses(chain, model_frames)
    body = fit_body(chain, model_frames, margin_mm, link_radius_mm)
    limits, notes = narrow_limits(chain, body, model_frames, limits, kin.sign, margin_mm)
    base2world, flange2tool0, sources = _controller_frames(chain)
    return RobotDescription(
        name=name or str(path),
        mdh=kin.mdh,
        joint_limits_rad=limits,
        max_joint_speed_rad_s=speeds,
        body=body,
        configurations={
            "home": (0.0,) * 6,
            "upright": upright(kin.mdh, limits, kin.base_offset),
        },
        mass_kg=None if masses is None else masses[0],
        com_mm=None if masses is None else masses[1],
        convention=JointConvention(
            sign=tuple(float(s) for s in kin.sign),
            source="the URDF's joint angles (ROS-Industrial drivers pass the controller's through)",
        ),
        base_offset=kin.base_offset,
        flange_offset=kin.flange_offset,
        source=f"URDF {Path(path).name} ({chain.robot}), {chain.base_link} to {chain.tip_link}",
        limit_notes=notes,
        base2controller_base=base2world,
        flange2controller_flange=flange2tool0,
        controller_base_source=sources[0],
        controller_flange_source=sources[1],
    )


def _controller_frames(chain: Chain) -> tuple[np.ndarray, np.ndarray, tuple[str, str]]:
    """The controller's base and flange frames of a chain, by REP-199's link names.

    A base link named with ``--base-link`` that is fixed beside the chain
    (:attr:`Chain.world_link`) is the base frame; else a link ``base`` fixed
    to the chain's base, else the chain's base link itself. The flange is a
    link ``tool0`` fixed to the tip, else the tip. A description file may
    name others (:mod:`calibrator.robots.files`).
    """
    name = chain.path.name
    world = chain.world_link or REP199_BASE
    base = controller_frame(chain, world, "base")
    flange = controller_frame(chain, REP199_FLANGE, "flange")
    why = "named as the base link" if chain.world_link else "REP-199's controller base frame"
    return (
        np.eye(4) if base is None else base,
        np.eye(4) if flange is None else flange,
        (
            "" if base is None else f"{name}: link {world!r} ({why})",
            "" if flange is None else f"{name}: link {REP199_FLANGE!r} (REP-199's all-zero tool)",
        ),
    )


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
    for k, names in enumerate(_groups(chain)):
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
                        _mesh(chain, geometry[0], origin_of(collision.find("origin"), where), where)
                        if geometry[0].tag == "mesh"
                        else None
                    )
                except _MeshMissing:
                    loaded = None
                if loaded is None:
                    complete = False
                    continue
                at = to_group @ frames[name]
                surface = clearance.surface_points(*loaded, SURFACE_SPACING_MM)
                points.append(surface @ at[:3, :3].T + at[:3, 3])
        out.append(np.concatenate(points) if complete and points else None)
    return out


def upright(mdh: np.ndarray, limits: np.ndarray, base_offset: np.ndarray) -> tuple[float, ...]:
    """Model angles holding the arm straight up with the flange pointing up.

    Joints 2 and 3 put the wrist (frame 5's origin) highest above the base
    link; joints 4 and 5 then point the flange's z axis most nearly up. Found
    on a 5-degree grid within the limits, refined on a half-degree one (the
    cell's via poses need no more).
    """

    def best(q0: np.ndarray, joints: tuple[int, int], score, step_deg: float, span_deg: float):
        axes = []
        for j in joints:
            grid = q0[j] + np.radians(np.arange(-span_deg, span_deg + step_deg / 2, step_deg))
            axes.append(grid[(grid >= limits[j, 0]) & (grid <= limits[j, 1])])
        a, b = np.meshgrid(*axes, indexing="ij")
        q = np.tile(q0, (a.size, 1))
        q[:, joints[0]], q[:, joints[1]] = a.ravel(), b.ravel()
        # Ties (a flat optimum) go to the smallest angles.
        return q[np.argmax(score(q) - 1e-6 * np.abs(q[:, joints]).sum(axis=1))]

    def wrist_height(q: np.ndarray) -> np.ndarray:
        return (base_offset @ kinematics.chain(mdh, q, all_frames=True)[1][:, 5])[:, 2, 3]

    def flange_up(q: np.ndarray) -> np.ndarray:
        return (base_offset @ kinematics.chain(mdh, q))[:, 2, 2]

    q = np.zeros(6)
    for score, joints in ((wrist_height, (1, 2)), (flange_up, (3, 4))):
        q = best(q, joints, score, 5.0, 360.0)
        q = best(q, joints, score, 0.5, 5.0)
    return tuple(float(v) for v in q)


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
    groups = _groups(chain)
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
                except _MeshMissing as exc:
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
                pm, qm = to_model @ p_base, to_model @ q_base
                capsules.append(
                    Capsule(
                        f"{name}" + (f" {k + 1}" if k else ""),
                        i,
                        tuple(float(v) for v in pm[:3]),  # type: ignore[arg-type]
                        tuple(float(v) for v in qm[:3]),  # type: ignore[arg-type]
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
                    tuple(float(v) for v in (to_model @ np.append(start, 1.0))[:3]),  # type: ignore[arg-type]
                    tuple(float(v) for v in (to_model @ np.append(end, 1.0))[:3]),  # type: ignore[arg-type]
                    r + margin_mm,
                )
            )
    joint1 = model_frames[0]
    if base_ends:
        # A vertical cylinder about the base z axis around every base capsule.
        pts, r_max = np.array(base_ends), max(base_radii)
        radius = float(np.max(np.hypot(pts[:, 0], pts[:, 1])) + r_max + margin_mm)
        top = float(pts[:, 2].max() + r_max)
        bottom = float(min(0.0, min(base_low)))
    else:
        # No geometry: a base under the shoulder, half its height.
        radius, bottom = BARE_LINK_RADIUS_MM * 1.5, 0.0
        top = _bare_base_top(model_frames)
    # The cell works in MDH frame 0: base cylinder heights and the shoulder in it.
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
_Fitted = tuple[np.ndarray, np.ndarray, float, np.ndarray | None]


def _fit(chain: Chain, link: str, collision: ET.Element) -> _Fitted | None:
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
    values = _numbers(shape.get(key), count, (0.0,) * count, f"{where} {key}") * _M
    if not np.all(values > 0):
        raise DescriptionError(f"{where}: {key} {shape.get(key)!r} must be > 0 (metres)")
    if np.any(values > MAX_MESH_EXTENT_MM):
        raise DescriptionError(
            f"{where}: {key} {shape.get(key)!r} m is no arm link's: written in millimetres? "
            "URDF lengths are metres"
        )
    return values


class _MeshMissing(Exception):
    """A collision mesh the URDF names and that cannot be found (its file name)."""


def mesh_file(urdf: Path, filename: str) -> Path | None:
    """The file a URDF's ``<mesh filename>`` names, where it can be found.

    ``package://pkg/rest`` is looked for as ROS finds it: in ``pkg`` beside
    the URDF's folder (the URDF in ``pkg/urdf/``), in a folder ``pkg`` in
    any folder above the URDF (a workspace), and in each folder of
    ``ROS_PACKAGE_PATH``. Other names are relative to the URDF's folder.
    """
    if not filename.startswith("package://"):
        found = urdf.parent / filename.removeprefix("file://")
        return found if found.is_file() else None
    package, _, rest = filename[len("package://") :].partition("/")
    roots = [p for p in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if p]
    candidates = [urdf.parent.parent / rest]
    candidates += [up / package / rest for up in urdf.resolve().parents]
    candidates += [Path(root) / package / rest for root in roots]
    return next((c for c in candidates if c.is_file()), None)


def _fit_mesh(chain: Chain, shape: ET.Element, at: np.ndarray, where: str) -> _Fitted | None:
    loaded = _mesh(chain, shape, at, where)
    if loaded is None:
        return None
    points = loaded[0]
    capsule = enclosing.enclose(points)
    return capsule.p, capsule.q, capsule.radius, points


def _mesh(
    chain: Chain, shape: ET.Element, at: np.ndarray, where: str
) -> tuple[np.ndarray, np.ndarray] | None:
    """A ``<mesh>``'s vertices in the link frame (mm) and faces, or None if it has none."""
    filename = str(shape.get("filename") or "")
    found = mesh_file(chain.path, filename)
    if found is None:
        raise _MeshMissing(filename)
    import trimesh

    # The scale first: a bad one is refused before the mesh file is even read.
    scale = _numbers(shape.get("scale"), 3, (1.0, 1.0, 1.0), f"{where} mesh scale")
    if not np.all(np.abs(scale) > 0):
        raise DescriptionError(f"{where}: mesh scale {shape.get('scale')!r} has a zero factor")
    size = found.stat().st_size
    if size > MAX_MESH_BYTES:
        raise DescriptionError(
            f"{where}: mesh {found.name} is {size / 2**20:.0f} MiB, more than the "
            f"{MAX_MESH_BYTES // 2**20} MiB a collision mesh is read up to"
        )
    try:
        mesh = trimesh.load(found, force="mesh")
    except Exception as exc:  # trimesh raises many kinds for bad files
        raise DescriptionError(f"{where}: cannot read mesh {found.name} ({exc})") from None
    points = np.asarray(getattr(mesh, "vertices", []), dtype=float)
    faces = np.asarray(getattr(mesh, "faces", np.empty((0, 3))), dtype=int).reshape(-1, 3)
    if points.ndim != 2 or len(points) < 3 or not len(faces):
        # A file trimesh opens but finds nothing in (not a mesh, a format it does not
        # know): named, never dropped as if the link had no collision geometry.
        raise DescriptionError(f"{where}: mesh {found.name} holds no triangles that could be read")
    if not np.all(np.isfinite(points)):
        raise DescriptionError(f"{where}: mesh {found.name} has vertices that are not numbers")
    # The extent from the file's numbers and the scale, compared before anything
    # is scaled (a scale of 1e308 would overflow into infinities).
    ratio = float(np.max(np.ptp(points, axis=0) * (np.abs(scale) * (_M / MAX_MESH_EXTENT_MM))))
    if not ratio <= 1.0:
        spans = f"{ratio * (MAX_MESH_EXTENT_MM / _M):.4g}" if np.isfinite(ratio) else "beyond 1e300"
        raise DescriptionError(
            f"{where}: mesh {found.name} spans {spans} m once scaled: no arm link's "
            '(URDF meshes are metres; a mesh in millimetres needs scale="0.001 0.001 0.001")'
        )
    if faces.min() < 0 or faces.max() >= len(points):
        raise DescriptionError(f"{where}: mesh {found.name} has faces of vertices it does not hold")
    points = points * scale * _M
    corners = points[faces]
    area_m2 = 0.5e-6 * float(
        np.linalg.norm(
            np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1
        ).sum()
    )
    if area_m2 > MAX_MESH_AREA_M2:
        raise DescriptionError(
            f"{where}: mesh {found.name} has {area_m2:.4g} m^2 of surface once scaled, more "
            f"than any arm link's ({MAX_MESH_AREA_M2:g} m^2)"
        )
    points = points @ at[:3, :3].T + at[:3, 3]
    return points, faces
