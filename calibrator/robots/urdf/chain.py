"""A URDF's serial chain: its joints and links as the file gives them (mm, rad)."""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from calibrator.inputs import grammar, textfile
from calibrator.inputs.errors import StrictError
from calibrator.model.frames import from_xyz_rpy
from calibrator.robots.description import (
    DescriptionError,
)

#: Refuse URDF files larger than this (a 6-axis arm's is tens of kilobytes).
MAX_BYTES = 16 * 2**20
MM_PER_M = 1000.0
#: A joint origin farther than this from its parent (mm) is no arm's: lengths written in
#: millimetres where URDF wants metres (a 400 mm link read as 400 m).
MAX_JOINT_OFFSET_MM = 10_000.0
#: A joint limit beyond this (rad, two turns) was written in degrees, where URDF wants radians.
MAX_LIMIT_RAD = 4 * np.pi


#: Base links tried when none is given, in order.
BASE_LINKS = ("base_link",)
#: Tip links tried when none is given, in order.
TIP_LINKS = ("tool0", "flange")


MOVING = ("revolute", "continuous")


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
        return tuple(j for j in self.joints if j.kind in MOVING)

    def link_frames(self) -> dict[str, np.ndarray]:
        """Every chain link's frame in the base link at the zero pose, mm."""
        frames = {self.base_link: np.eye(4)}
        for joint in self.joints:
            frames[joint.child] = frames[joint.parent] @ joint.origin
        return frames


def fail(path: Path | str, what: str) -> DescriptionError:
    return DescriptionError(f"{path}: {what}")


def numbers(text: str | None, count: int, default: tuple[float, ...], where: str) -> np.ndarray:
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
    xyz = numbers(element.get("xyz"), 3, (0.0, 0.0, 0.0), f"{where} origin xyz")
    rpy = numbers(element.get("rpy"), 3, (0.0, 0.0, 0.0), f"{where} origin rpy")
    if np.any(np.abs(xyz) > MAX_JOINT_OFFSET_MM / MM_PER_M):  # before scaling: 1e308 m overflows
        raise DescriptionError(
            f"{where}: origin xyz {element.get('xyz')!r:.60} is beyond "
            f"{MAX_JOINT_OFFSET_MM / MM_PER_M:g} m, no arm's: written in millimetres? "
            "URDF lengths are metres"
        )
    if np.any(np.abs(rpy) > MAX_LIMIT_RAD):
        raise DescriptionError(
            f"{where}: origin rpy {element.get('rpy')!r:.60} is more than two turns: "
            "written in degrees? URDF angles are radians"
        )
    return from_xyz_rpy(np.concatenate([xyz * MM_PER_M, rpy]))


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
        raise fail(path, f"not a URDF file (XML error: {exc})") from None
    if root.tag != "robot":
        raise fail(path, f"not a URDF file (the root element is <{root.tag}>, not <robot>)")
    links = {e.get("name") for e in root.findall("link")}
    by_child: dict[str, ET.Element] = {}
    for element in root.findall("joint"):
        child = element.find("child")
        if child is not None and child.get("link"):
            by_child[str(child.get("link"))] = element

    def pick(given: str | None, defaults: tuple[str, ...], what: str) -> str:
        if given is not None:
            if not isinstance(given, str):  # a description file's tip_link: [a, b]
                raise fail(path, f"the {what} link must be one link's name, got {given!r:.60}")
            if given not in links:
                raise fail(
                    path, f"no {what} link {given!r} (links: {', '.join(sorted(map(str, links)))})"
                )
            return given
        for name in defaults:
            if name in links:
                return name
        raise fail(path, f"no {what} link ({' or '.join(defaults)}); name it with --{what}-link")

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
            raise fail(path, "the joints form a loop")
    world = None
    if above[-1] != base:
        # Not above the tip: a frame fixed to the chain's base (FANUC's ``base``
        # hangs off base_link) is the controller's base frame, the chain starts
        # at the link it is fixed to.
        moving = [i for i, e in enumerate(elements) if e.get("type") in MOVING]
        below_first = above[moving[-1] + 1 :] if moving else []
        attached = fixed_to(root, base, set(below_first))
        if attached is None:
            raise fail(path, f"link {tip!r} is not below {base!r} on one chain")
        world, base = base, attached[0]
        elements = elements[: above.index(base)]
    joints = tuple(_joint(path, e) for e in reversed(elements))
    return Chain(path, str(root.get("name") or path.stem), base, tip, joints, root, world)


def fixed_to(root: ET.Element, link: str, targets: set[str]) -> tuple[str, np.ndarray] | None:
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


def _joint(path: Path, element: ET.Element) -> Joint:
    name = str(element.get("name"))
    kind = str(element.get("type"))
    where = f"{path}: joint {name!r}"
    if element.find("mimic") is not None:
        raise DescriptionError(f"{where} mimics another joint: coupled chains are not supported")
    if kind not in (*MOVING, "fixed"):
        what = {"prismatic": "a linear axis or track", "planar": "a planar joint"}.get(
            kind, f"a {kind} joint"
        )
        raise DescriptionError(
            f"{where} is {kind} ({what}): only serial 6-axis arms of revolute joints are supported"
        )
    parent, child = element.find("parent"), element.find("child")
    axis = numbers(
        element.find("axis").get("xyz") if element.find("axis") is not None else None,  # type: ignore[union-attr]
        3,
        (1.0, 0.0, 0.0),
        f"{where} axis",
    )
    if kind in MOVING and not np.linalg.norm(axis) > 1e-9:
        raise DescriptionError(f"{where}: its axis is zero")
    limit = element.find("limit")
    lower = upper = velocity = None
    if limit is not None:
        for key in ("lower", "upper", "velocity"):
            if limit.get(key) is not None:
                value = numbers(limit.get(key), 1, (0.0,), f"{where} limit {key}")[0]
                if key == "lower":
                    lower = value
                elif key == "upper":
                    upper = value
                else:
                    velocity = value
    origin = origin_of(element.find("origin"), where)
    if np.linalg.norm(origin[:3, 3]) > MAX_JOINT_OFFSET_MM:
        raise DescriptionError(
            f"{where}: its origin is {np.linalg.norm(origin[:3, 3]) / MM_PER_M:.4g} m from its "
            "parent, "
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


def link_groups(chain: Chain) -> list[list[str]]:
    """Link names riding on the base (0) and on each moving joint (1..6)."""
    groups: list[list[str]] = [[chain.base_link]]
    for joint in chain.joints:
        if joint.kind in MOVING:
            groups.append([])
        groups[-1].append(joint.child)
    return groups
