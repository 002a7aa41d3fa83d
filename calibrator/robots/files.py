"""The robot description file: YAML, format ``calibrator-robot/1`` (docs/robots.md).

A description file names the arm and gives its kinematics either as a URDF
(``kinematics: {urdf: arm.urdf, base_link: ..., tip_link: ...}``, the path
relative to the file) or as an MDH table; then, optionally, limits, the
controller's joint convention, the body, named configurations and masses.
Angles in the file are degrees (as on a pendant), lengths millimetres::

    format: calibrator-robot/1
    name: my-arm
    source: where the numbers come from
    kinematics:
      mdh:                       # a_mm, alpha_deg, theta_deg, d_mm, beta_deg
        - [150, -90, 0, 450, 0]
        ...                      # six rows
    limits:                      # required with mdh; override a URDF's
      lower_deg: [-170, -190, -120, -185, -120, -350]
      upper_deg: [170, 45, 156, 185, 120, 350]
      speed_deg_s: [360, 300, 360, 381, 388, 615]
      accel_deg_s2: [...]        # optional
    convention:                  # controller angle -> kinematics angle (the URDF's, or q)
      sign: [1, 1, 1, 1, 1, 1]
      offset_deg: [0, 0, 0, 0, 0, 0]
      couplings: [{joint: 3, from: 2, factor: 1}]   # joints 1-based
      source: where the convention comes from
    body:
      margin_mm: 10
      base_radius_mm: 120
      base_top_mm: 300
      mount_z_mm: 0
      link_radius_mm: [110, 90, 80, 70, 60, 50]     # capsules along the links, or:
      capsules:                  # base frame, every joint at zero
        - {name: forearm, link: 3, p_mm: [x, y, z], q_mm: [x, y, z], radius_mm: 70}
    configurations:              # controller angles, deg
      home: [0, -90, 90, 0, 0, 0]
      upright: [0, -90, 0, 0, 0, 0]
    masses:
      mass_kg: [6 numbers]
      com_mm: [[x, y, z], ...]   # in link frame i of the MDH model
    frames:                      # the controller's base (world) frame and flange (tool 0)
      base: {link: base, source: ...}          # a URDF link fixed to the chain's base, or
      flange: {xyz_mm: [0, 0, 0], rpy_deg: [0, 90, 0], source: ...}   # or matrix_mm: 4x4

Read with the strict YAML reader (duplicate keys, ``.nan`` and the like are
refused) behind :func:`_parse`, the one place that parses YAML here.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from calibrator.inputs import textfile, yamlfile
from calibrator.inputs.errors import StrictError
from calibrator.model import frames as transforms
from calibrator.model import kinematics
from calibrator.robots import urdf
from calibrator.robots.description import (
    FORMAT,
    Body,
    Capsule,
    DescriptionError,
    JointConvention,
    RobotDescription,
    rigid,
)

#: Refuse description files larger than this.
MAX_BYTES = 2**20
#: Most capsules, named configurations and couplings a file may list: each
#: costs every clearance check or plan (a 1 MiB file could list 20,000).
MAX_ITEMS = {"capsules": 64, "configurations": 64, "couplings": 15}
_DEG = np.pi / 180.0
_KEYS = {
    "format",
    "name",
    "title",
    "family",
    "source",
    "kinematics",
    "limits",
    "convention",
    "body",
    "configurations",
    "masses",
    "frames",
}
#: Keys of one entry of ``frames:``.
_FRAME_KEYS = {"link", "xyz_mm", "rpy_deg", "matrix_mm", "source"}


def _parse(text: str, where: str) -> Any:
    """The one YAML parse of this module (strict: unique keys, strict numbers)."""
    try:
        return yamlfile.loads(text, where)
    except StrictError as exc:
        raise DescriptionError(str(exc)) from None


class _Doc:
    """Typed access to a mapping, naming the file and key in every error."""

    def __init__(self, doc: Any, where: str):
        if not isinstance(doc, Mapping):
            raise DescriptionError(f"{where}: must be a mapping")
        self.doc, self.where = doc, where

    def fail(self, key: str, what: str) -> DescriptionError:
        return DescriptionError(f"{self.where}: {key}: {what}")

    def get(self, key: str) -> Any:
        return self.doc.get(key)

    def text(self, key: str, default: str | None = None) -> str:
        value = self.doc.get(key, default)
        if not isinstance(value, str) or not value.strip():
            raise self.fail(key, "must be a non-empty text")
        return value.strip()

    def numbers(self, key: str, shape: tuple[int, ...]) -> np.ndarray:
        value = self.doc.get(key)
        try:
            array = np.array(value, dtype=float)
        except (TypeError, ValueError):
            raise self.fail(key, f"must be numbers, shape {shape}") from None
        if array.shape != shape or not np.all(np.isfinite(array)) or _has_bool(value):
            raise self.fail(key, f"must be finite numbers, shape {shape}")
        return array

    def positive(self, key: str, shape: tuple[int, ...], zero_ok: bool = False) -> np.ndarray:
        """:meth:`numbers` that are lengths: > 0 (>= 0 with ``zero_ok``)."""
        array = self.numbers(key, shape)
        if not np.all(array >= 0 if zero_ok else array > 0):
            raise self.fail(key, "must be >= 0" if zero_ok else "must be > 0 (a length, mm)")
        return array

    def section(self, key: str) -> _Doc | None:
        value = self.doc.get(key)
        return None if value is None else _Doc(value, f"{self.where}: {key}")


def _count(section: _Doc, key: str) -> None:
    """Refuse a list ``key`` that is no list or longer than :data:`MAX_ITEMS` allows."""
    items = section.get(key)
    if not isinstance(items, list):
        raise section.fail(key, "must be a list")
    if len(items) > MAX_ITEMS[key]:
        raise section.fail(key, f"{len(items)} listed, at most {MAX_ITEMS[key]}")


def _has_bool(value: Any) -> bool:
    if isinstance(value, bool):
        return True
    if isinstance(value, list | tuple):
        return any(_has_bool(v) for v in value)
    return False


def is_description(path: str | Path) -> bool:
    """Whether the file at ``path`` says it is a robot description (its ``format:`` line)."""
    try:
        with open(path, encoding="utf-8", errors="replace") as stream:
            head = stream.read(4096)
    except OSError:
        return False
    return any(line.split("#")[0].strip() == f"format: {FORMAT}" for line in head.splitlines())


def load(path: str | Path, name: str | None = None) -> RobotDescription:
    """Read a description file (see the module docstring).

    Parameters
    ----------
    path : str or Path
    name : str, optional
        The description's name [default: the file's own ``name``].

    Raises
    ------
    DescriptionError
        One line naming the file, the key and what is wrong.
    """
    path = Path(path)
    try:
        return _load(path, name)
    except DescriptionError as exc:
        # What the description's own checks refuse (a capsule, an offset, a
        # configuration outside the limits) is said with the file it came from.
        if str(exc).startswith(str(path)):
            raise
        raise DescriptionError(f"{path}: {exc}") from None


def _load(path: Path, name: str | None) -> RobotDescription:
    try:
        text = textfile.read_text(path, MAX_BYTES, "a robot description")
    except StrictError as exc:
        raise DescriptionError(str(exc)) from None
    doc = _Doc(_parse(text, str(path)), str(path))
    unknown = sorted(set(map(str, doc.doc)) - _KEYS)
    if unknown:
        raise doc.fail(unknown[0], f"unknown key (known: {', '.join(sorted(_KEYS))})")
    if doc.get("format") != FORMAT:
        raise doc.fail("format", f"must be {FORMAT!r}, got {doc.get('format')!r}")
    kin = doc.section("kinematics")
    if kin is None:
        raise doc.fail("kinematics", "missing (give urdf: or mdh:)")
    if (kin.get("urdf") is None) == (kin.get("mdh") is None):
        raise doc.fail("kinematics", "give exactly one of urdf: and mdh:")
    if kin.get("urdf") is not None:
        body = doc.section("body")
        radii = margin = None
        if body is not None and body.get("link_radius_mm") is not None:
            radii = body.positive("link_radius_mm", (6,))
        if body is not None and body.get("margin_mm") is not None:
            margin = float(body.positive("margin_mm", (), zero_ok=True))
        links = {}
        for key in ("base_link", "tip_link"):
            if kin.get(key) is not None:
                links[key] = kin.text(key)  # one link's name, never a list or a number
        base = urdf.describe(
            path.parent / kin.text("urdf"),
            base_link=links.get("base_link"),
            tip_link=links.get("tip_link"),
            name="file",
            margin_mm=urdf.FIT_MARGIN_MM if margin is None else margin,
            link_radius_mm=radii,
        )
    else:
        base = _from_mdh(doc, kin)
    base = _controller_frames(doc, kin, path, base)
    return _overlay(doc, base, name or doc.text("name").lower())


def _controller_frames(doc: _Doc, kin: _Doc, path: Path, base: RobotDescription):
    """The ``frames:`` section over what the kinematics gave (REP-199's links of a URDF).

    ``base`` is the controller's base (world) frame in the description's base
    frame (the URDF's base link, or MDH frame 0), ``flange`` its tool 0 in the
    description's flange frame (the URDF's tip link, or the MDH flange): a
    link of the URDF fixed to that end, or ``xyz_mm`` with ``rpy_deg`` (the
    URDF's fixed-axis roll, pitch, yaw), or ``matrix_mm`` (4x4); each with its
    ``source``.
    """
    section = doc.section("frames")
    if section is None:
        return base
    unknown = sorted(set(map(str, section.doc)) - {"base", "flange"})
    if unknown:
        raise section.fail(unknown[0], "unknown key (known: base, flange)")
    changes: dict[str, Any] = {}
    for end, field in (("base", "base2controller_base"), ("flange", "flange2controller_flange")):
        entry = section.section(end)
        if entry is None:
            continue
        extra = sorted(set(map(str, entry.doc)) - _FRAME_KEYS)
        if extra:
            raise entry.fail(extra[0], f"unknown key (known: {', '.join(sorted(_FRAME_KEYS))})")
        given = [k for k in ("link", "xyz_mm", "matrix_mm") if entry.get(k) is not None]
        if len(given) != 1:
            raise entry.fail(end, "give exactly one of link, xyz_mm (with rpy_deg), matrix_mm")
        if given[0] == "link":
            if kin.get("urdf") is None:
                raise entry.fail("link", "names a URDF link: needs kinematics from a URDF")
            chain = urdf.read_chain(
                path.parent / kin.text("urdf"), kin.get("base_link"), kin.get("tip_link")
            )
            link = entry.text("link")
            pose = urdf.controller_frame(chain, link, end)
            if pose is None:
                anchor = chain.base_link if end == "base" else chain.tip_link
                raise entry.fail(
                    "link", f"{link!r} is not a link fixed to the chain's {end} ({anchor!r})"
                )
        elif given[0] == "xyz_mm":
            rpy = entry.numbers("rpy_deg", (3,)) if entry.get("rpy_deg") is not None else None
            if rpy is None:
                raise entry.fail("rpy_deg", "missing: give it with xyz_mm")
            pose = transforms.from_xyz_rpy(
                np.concatenate([entry.numbers("xyz_mm", (3,)), rpy * _DEG])
            )
        else:
            pose = entry.numbers("matrix_mm", (4, 4))
            try:
                transforms.check_transform(pose, "matrix_mm")
            except ValueError as exc:
                raise entry.fail("matrix_mm", str(exc)) from None
        changes[field] = pose
        changes[f"controller_{end}_source"] = entry.text("source")
    try:
        return replace(base, **changes)
    except DescriptionError as exc:
        raise DescriptionError(f"{section.where}: {exc}") from None


def _from_mdh(doc: _Doc, kin: _Doc) -> RobotDescription:
    table = kin.numbers("mdh", (6, 5))
    mdh = table.copy()
    mdh[:, [kinematics.ALPHA, kinematics.THETA, kinematics.BETA]] *= _DEG
    limits = doc.section("limits")
    if limits is None:
        raise doc.fail("limits", "required with an MDH table")
    lower, upper = limits.numbers("lower_deg", (6,)), limits.numbers("upper_deg", (6,))
    base_offset, flange_offset = (
        kin.numbers(key, (4, 4)) if kin.get(key) is not None else np.eye(4)
        for key in ("base_offset", "flange_offset")
    )
    for key, offset in (("base_offset", base_offset), ("flange_offset", flange_offset)):
        try:
            rigid(offset, key)
        except DescriptionError as exc:
            raise kin.fail(key, str(exc).removeprefix(f"{key} ")) from None
    return RobotDescription(
        name="file",
        mdh=mdh,
        joint_limits_rad=np.column_stack([lower, upper]) * _DEG,
        max_joint_speed_rad_s=limits.numbers("speed_deg_s", (6,)) * _DEG,
        configurations={"home": (0.0,) * 6},
        base_offset=base_offset,
        flange_offset=flange_offset,
    )


def _overlay(doc: _Doc, base: RobotDescription, name: str) -> RobotDescription:
    """The file's own sections over what the kinematics gave."""
    convention = _convention(doc, base.convention)
    changes: dict[str, Any] = {
        "name": name,
        "family": doc.text("family", base.family),
        "source": doc.text("source", base.source),
        "convention": convention,
    }
    limits = doc.section("limits")
    if limits is not None:
        lim = np.array(base.joint_limits_rad)
        # Limits in the file are controller angles: take them to the model's.
        for key, col in (("lower_deg", 0), ("upper_deg", 1)):
            if limits.get(key) is not None:
                lim[:, col] = limits.numbers(key, (6,)) * _DEG
        if limits.get("lower_deg") is not None or limits.get("upper_deg") is not None:
            if np.any(lim[:, 0] >= lim[:, 1]):
                raise limits.fail("lower_deg", "every joint needs lower_deg < upper_deg")
            if convention.couplings:
                if limits.get("lower_deg") is None or limits.get("upper_deg") is None:
                    raise limits.fail(
                        "lower_deg", "give lower_deg and upper_deg together for coupled joints"
                    )
                # A coupled joint's limit is the controller's (FANUC's J3 from the
                # horizon): kept as stated and checked as such; the model's box
                # around it is where poses are drawn from.
                changes["controller_limits_rad"] = lim
                lim = convention.model_box(lim)
            else:
                lim = np.sort(convention.to_model(lim.T).T, axis=1)
        changes["joint_limits_rad"] = lim
        if limits.get("speed_deg_s") is not None:
            changes["max_joint_speed_rad_s"] = limits.numbers("speed_deg_s", (6,)) * _DEG
        if limits.get("accel_deg_s2") is not None:
            changes["max_joint_accel_rad_s2"] = limits.numbers("accel_deg_s2", (6,)) * _DEG
    configs = doc.section("configurations")
    if configs is not None:
        if len(configs.doc) > MAX_ITEMS["configurations"]:
            raise doc.fail("configurations", f"more than {MAX_ITEMS['configurations']} named")
        named = dict(base.configurations)
        for key in configs.doc:
            q = configs.numbers(str(key), (6,)) * _DEG
            named[str(key)] = tuple(float(v) for v in convention.to_model(q))
        changes["configurations"] = named
    masses = doc.section("masses")
    if masses is not None:
        changes["mass_kg"] = masses.numbers("mass_kg", (6,))
        changes["com_mm"] = masses.numbers("com_mm", (6, 3))
    body = doc.section("body")
    if body is not None:
        changes["body"] = _body(body, base)
    elif base.body is None:
        raise doc.fail("body", "missing: give capsules or link_radius_mm")
    return replace(base, **changes)


def _convention(doc: _Doc, kinematics_convention: JointConvention) -> JointConvention:
    """Controller -> model: the file's controller -> kinematics, then the kinematics' sign."""
    section = doc.section("convention")
    u = np.array(kinematics_convention.sign)
    if section is None:
        return kinematics_convention
    sign = section.numbers("sign", (6,)) if section.get("sign") is not None else np.ones(6)
    offset = (
        section.numbers("offset_deg", (6,)) * _DEG
        if section.get("offset_deg") is not None
        else np.zeros(6)
    )
    couplings = []
    if section.get("couplings") is not None:
        _count(section, "couplings")
    for k, item in enumerate(section.get("couplings") or []):
        c = _Doc(item, f"{section.where}: couplings[{k}]")
        j, src, f = (c.numbers(key, ()) for key in ("joint", "from", "factor"))
        for key, value in (("joint", j), ("from", src)):
            if value != int(value) or not 1 <= value <= 6:
                raise c.fail(key, f"{value:g}: joints are numbered 1 to 6")
        if not src < j:
            raise c.fail("from", "a joint is coupled to an earlier joint (from < joint)")
        couplings.append((int(j) - 1, int(src) - 1, float(u[int(j) - 1] * f)))
    try:
        return JointConvention(
            sign=tuple(float(v) for v in u * sign),
            offset_rad=tuple(float(v) for v in u * offset),
            couplings=tuple(couplings),
            source=section.text("source"),
        )
    except DescriptionError as exc:
        raise DescriptionError(f"{section.where}: {exc}") from None


def _body(section: _Doc, base: RobotDescription) -> Body:
    frames = base.base_offset @ kinematics.chain(base.mdh, np.zeros(6), all_frames=True)[1][0]
    margin = (
        float(section.positive("margin_mm", (), zero_ok=True))
        if section.get("margin_mm") is not None
        else 0.0
    )
    capsules: list[Capsule] = []
    if section.get("capsules") is not None:
        _count(section, "capsules")
        for k, item in enumerate(section.get("capsules")):
            c = _Doc(item, f"{section.where}: capsules[{k}]")
            link = c.numbers("link", ())
            if link not in range(1, 7):
                raise c.fail("link", "must be 1 to 6")
            to_link = np.linalg.inv(frames[int(link)])
            p = to_link @ np.append(c.numbers("p_mm", (3,)), 1.0)
            q = to_link @ np.append(c.numbers("q_mm", (3,)), 1.0)
            capsules.append(
                Capsule(
                    c.text("name"),
                    int(link),
                    (float(p[0]), float(p[1]), float(p[2])),
                    (float(q[0]), float(q[1]), float(q[2])),
                    float(c.positive("radius_mm", ())) + margin,
                )
            )
    elif section.get("link_radius_mm") is not None:
        # The URDF reader drew the capsules along the links with these radii.
        if base.body is None:
            raise section.fail("link_radius_mm", "needs kinematics from a URDF: give capsules")
        capsules = list(base.body.capsules)
        # ... with its margin (the file's margin_mm, else the fit's default: _load), not 0:
        # a file without margin_mm was refused as if its kinematics were no URDF's.
        margin = base.body.margin_mm
    else:
        if base.body is None:
            raise section.fail("capsules", "missing: give capsules or link_radius_mm")
        capsules = list(base.body.capsules)
        margin = base.body.margin_mm  # what they hold: not 0 where the file gives none
    old = base.body
    shift = float(base.base_offset[2, 3])

    def number(key: str, default: float) -> float:
        return float(section.numbers(key, ())) if section.get(key) is not None else default

    base_radius = (
        float(section.positive("base_radius_mm", ()))
        if section.get("base_radius_mm") is not None
        else (old.base_radius_mm if old else 150.0)
    )
    return Body(
        capsules=tuple(capsules),
        base_radius_mm=base_radius,
        base_top_mm=number("base_top_mm", old.base_top_mm if old else 0.0),
        mount_z_mm=number("mount_z_mm", old.mount_z_mm if old else -shift),
        shoulder_mm=(0.0, 0.0, float(frames[1][2, 3] - shift)),
        margin_mm=margin,
        source=section.text("source", old.source if old else "the description file"),
    )
