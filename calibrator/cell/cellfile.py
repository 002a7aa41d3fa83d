"""The cell around the arm: mounting plane, obstacles, tracker. Read from YAML.

A cell file (all lengths mm, positions in the robot base frame)::

    mounting_plane_z_mm: 0      # the plane the robot stands on [default: the model's]
    margin_mm: 20               # clearance kept from plane, obstacles and other links
    tracker:
      at_mm: [2500, 400, 300]   # tracker head (beam origin)
      min_range_mm: 800         # closest measurable reflector distance
      max_range_mm: 20000
      acceptance_deg: 30        # reflector's acceptance half-angle
    obstacles:
      - box: {name: table, min_mm: [400, -600, -900], max_mm: [1200, 600, -20]}
      - cylinder: {name: tripod, centre_xy_mm: [2500, 400], radius_mm: 350,
                   z_mm: [-1200, 150]}

Every key is checked: an unknown key, a missing field, a non-finite number
or an empty box is refused with the key named.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from calibrator.errors import CalibrationError
from calibrator.inputs.messages import shown


class CellError(CalibrationError):
    """A cell, a pose, a motion or a plan that the cell does not allow."""


@dataclass(frozen=True)
class Box:
    """Axis-aligned box in the base frame, corners ``lo`` < ``hi`` (3,), mm."""

    name: str
    lo: tuple[float, float, float]
    hi: tuple[float, float, float]


@dataclass(frozen=True)
class Cylinder:
    """Vertical solid cylinder in the base frame, mm."""

    name: str
    centre_xy: tuple[float, float]
    radius: float
    z_lo: float
    z_hi: float


@dataclass(frozen=True)
class Cell:
    """What surrounds the arm.

    Attributes
    ----------
    mounting_plane_z_mm : float or None
        z of the plane the robot stands on, base frame, mm; None: the model's
        own (0 for UR arms, whose base frame is on the mounting flange).
    margin_mm : float
        Clearance every capsule keeps from the plane, the base, obstacles and
        non-adjacent links, mm.
    boxes, cylinders : tuple
        Obstacles (fixtures, the tracker's tripod).
    tracker_at_mm : tuple of 3 float, or None
        Tracker head position, base frame, mm; None skips the tracker checks.
    min_range_mm, max_range_mm : float
        The tracker's measuring range, mm.
    acceptance_deg : float
        Reflector acceptance half-angle, deg.
    beam_clearance_mm : float
        Clearance of the beam from every capsule and obstacle, mm.
    """

    mounting_plane_z_mm: float | None = None
    margin_mm: float = 20.0
    boxes: tuple[Box, ...] = ()
    cylinders: tuple[Cylinder, ...] = ()
    tracker_at_mm: tuple[float, float, float] | None = None
    min_range_mm: float = 800.0
    max_range_mm: float = 20000.0
    acceptance_deg: float = 30.0
    beam_clearance_mm: float = 10.0

    def with_tracker(self, at_mm: Iterable[float] | None) -> Cell:
        """This cell with the tracker at ``at_mm`` (3,), mm (None: unchanged)."""
        if at_mm is None:
            return self
        x, y, z = (float(v) for v in at_mm)
        return replace(self, tracker_at_mm=(x, y, z))


#: Largest cell file (bytes): 100 obstacles with comments are about 15 kB; a
#: 280 kB file took 2.5 s to read, so this bounds a refused one's cost too.
MAX_BYTES = 256 * 2**10
#: Most obstacles: every pose and move is checked against each. A UR10e move
#: of up to 2 rad per joint took 5 ms with 10 obstacles, 18 ms with 100, 75 ms
#: with 500 and 700 ms with 5,000 (pose_faults/motion_faults on 100 random
#: poses, one core); 100 keeps a 2,000-pose plan's check under a minute.
MAX_OBSTACLES = 100
#: Longest obstacle name (characters).
MAX_NAME = 80

_TOP = {"mounting_plane_z_mm", "margin_mm", "tracker", "obstacles", "beam_clearance_mm"}
_TRACKER = {"at_mm", "min_range_mm", "max_range_mm", "acceptance_deg"}


def _number(value, where: str, *, low: float = -1e6, high: float = 1e6) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise CellError(f"{where}: expected a number, got {shown(value)}")
    # Compare before float(): a huge int would overflow there.
    if not (low <= value <= high) or not math.isfinite(float(value)):
        raise CellError(f"{where}: {shown(value)} is not within [{low:g}, {high:g}]")
    return float(value)


def _vector(value, n: int, where: str) -> tuple[float, ...]:
    if not isinstance(value, list) or len(value) != n:
        raise CellError(f"{where}: expected a list of {n} numbers, got {shown(value)}")
    return tuple(_number(v, f"{where}[{i}]") for i, v in enumerate(value))


def _keys(doc, allowed: set[str], required: set[str], where: str) -> dict:
    if not isinstance(doc, dict):
        raise CellError(f"{where}: expected a mapping, got {type(doc).__name__}")
    # Plain keys as written; anything else (long, odd or not text) shortened.
    unknown = sorted(
        k if isinstance(k, str) and len(k) <= 40 and k.isprintable() else shown(k)
        for k in doc
        if k not in allowed
    )
    if unknown:
        raise CellError(f"{where}: unknown key(s) {', '.join(unknown[:5])}")
    missing = sorted(required - set(doc))
    if missing:
        raise CellError(f"{where}: missing {', '.join(missing)}")
    return doc


def _name(spec: dict, default: str, where: str) -> str:
    """An obstacle's name: text of one line, short enough for a message."""
    name = spec.get("name", default)
    if isinstance(name, bool) or not isinstance(name, str | int | float):
        raise CellError(f"{where}.name: expected a name (text), got {shown(name)}")
    name = str(name)
    if len(name) > MAX_NAME or not name.isprintable():
        raise CellError(
            f"{where}.name: {shown(name)} is not a name (one line of at most {MAX_NAME} characters)"
        )
    return name


def _obstacle(item, i: int) -> Box | Cylinder:
    where = f"obstacles[{i}]"
    item = _keys(item, {"box", "cylinder"}, set(), where)
    if len(item) != 1:
        raise CellError(f"{where}: give exactly one of box, cylinder")
    kind, spec = next(iter(item.items()))
    where = f"{where}.{kind}"
    if kind == "box":
        spec = _keys(spec, {"name", "min_mm", "max_mm"}, {"min_mm", "max_mm"}, where)
        lo, hi = (
            _vector(spec["min_mm"], 3, f"{where}.min_mm"),
            _vector(spec["max_mm"], 3, f"{where}.max_mm"),
        )
        if not all(a < b for a, b in zip(lo, hi, strict=True)):
            raise CellError(f"{where}: min_mm must be below max_mm on every axis")
        return Box(_name(spec, f"box {i}", where), lo, hi)  # type: ignore[arg-type]
    spec = _keys(
        spec,
        {"name", "centre_xy_mm", "radius_mm", "z_mm"},
        {"centre_xy_mm", "radius_mm", "z_mm"},
        where,
    )
    xy = _vector(spec["centre_xy_mm"], 2, f"{where}.centre_xy_mm")
    radius = _number(spec["radius_mm"], f"{where}.radius_mm", low=0.0)
    z = _vector(spec["z_mm"], 2, f"{where}.z_mm")
    if not z[0] < z[1] or radius <= 0.0:
        raise CellError(f"{where}: needs radius_mm > 0 and z_mm [low, high] with low < high")
    name = _name(spec, f"cylinder {i}", where)
    return Cylinder(name, xy, radius, z[0], z[1])  # type: ignore[arg-type]


def parse_cell(doc: Any) -> Cell:
    """A :class:`Cell` from a parsed YAML document (a mapping); raises CellError."""
    if doc is None:
        return Cell()
    doc = _keys(doc, _TOP, set(), "cell file")
    kwargs: dict = {}
    if "mounting_plane_z_mm" in doc:
        kwargs["mounting_plane_z_mm"] = _number(doc["mounting_plane_z_mm"], "mounting_plane_z_mm")
    for key in ("margin_mm", "beam_clearance_mm"):
        if key in doc:
            kwargs[key] = _number(doc[key], key, low=0.0, high=1000.0)
    if "tracker" in doc:
        tracker = _keys(doc["tracker"], _TRACKER, set(), "tracker")
        if "at_mm" in tracker:
            kwargs["tracker_at_mm"] = _vector(tracker["at_mm"], 3, "tracker.at_mm")
        for key in ("min_range_mm", "max_range_mm"):
            if key in tracker:
                kwargs[key] = _number(tracker[key], f"tracker.{key}", low=0.0)
        if "acceptance_deg" in tracker:
            kwargs["acceptance_deg"] = _number(
                tracker["acceptance_deg"], "tracker.acceptance_deg", low=0.0, high=90.0
            )
    obstacles = doc.get("obstacles") or []
    if not isinstance(obstacles, list):
        raise CellError("obstacles: expected a list")
    if len(obstacles) > MAX_OBSTACLES:
        raise CellError(
            f"obstacles: {len(obstacles)} is more than the limit of {MAX_OBSTACLES} "
            "(every pose and move is checked against each; merge small ones into boxes)"
        )
    parsed = [_obstacle(item, i) for i, item in enumerate(obstacles)]
    kwargs["boxes"] = tuple(o for o in parsed if isinstance(o, Box))
    kwargs["cylinders"] = tuple(o for o in parsed if isinstance(o, Cylinder))
    cell = Cell(**kwargs)
    if cell.min_range_mm >= cell.max_range_mm:
        raise CellError("tracker: min_range_mm must be below max_range_mm")
    return cell


def read_cell(path: str | os.PathLike[str]) -> Cell:
    """Read a cell file (YAML); one :class:`CellError` line naming what is wrong.

    The text is read by :func:`calibrator.inputs.yamlfile.read` (size, depth and
    alias limits, duplicate keys refused, strict numbers).
    """
    from calibrator.inputs import yamlfile
    from calibrator.inputs.errors import StrictError

    try:
        doc = yamlfile.read(path, "a cell file", MAX_BYTES)
    except StrictError as exc:
        raise CellError(str(exc)) from None
    try:
        return parse_cell(doc)
    except CellError as exc:
        raise CellError(f"{path}: {exc}") from None


def obstacle_arrays(cell: Cell) -> dict[str, np.ndarray]:
    """The obstacles as arrays: ``box_lo``, ``box_hi`` (B, 3); ``cyl`` (C, 5) xy, r, z_lo, z_hi."""
    return {
        "box_lo": np.array([b.lo for b in cell.boxes], dtype=float).reshape(-1, 3),
        "box_hi": np.array([b.hi for b in cell.boxes], dtype=float).reshape(-1, 3),
        "cyl": np.array(
            [(*c.centre_xy, c.radius, c.z_lo, c.z_hi) for c in cell.cylinders], dtype=float
        ).reshape(-1, 5),
    }
