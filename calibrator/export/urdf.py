"""``urdf``: a URDF of the calibrated arm (metres, radians).

Links ``base_link``, ``shoulder_link`` ... ``wrist_3_link`` as in UR's
description, then fixed joints to ``flange`` (the MDH flange frame, holding
``a6, alpha6, beta6`` that the kinematics YAML cannot) and ``tool`` (the
identified ``flange2tool``). The joint origins are those of
:func:`calibrator.model.kinematics.joint_origins`. Nothing is lost: the chain
``base_link -> flange`` is the calibrated ``A_1 ... A_6``.
"""

from __future__ import annotations

import os
import re
from typing import TYPE_CHECKING
from xml.sax.saxutils import quoteattr

import numpy as np

from calibrator import robots
from calibrator.errors import CalibrationError
from calibrator.export.registry import Exported, exporter
from calibrator.export.ros import JOINTS
from calibrator.model import kinematics
from calibrator.model.frames import xyz_rpy

if TYPE_CHECKING:
    from calibrator.calibration import Calibration


_M = 1000.0
JOINT_NAMES = ("shoulder_pan", "shoulder_lift", "elbow", "wrist_1", "wrist_2", "wrist_3")
LINKS = ("base_link",) + tuple(f"{j}_link" for j in JOINTS)


def _origin(transform):
    values = xyz_rpy(transform)
    values[:3] /= _M
    xyz = " ".join(repr(float(v)) for v in values[:3])
    rpy = " ".join(repr(float(v)) for v in values[3:])
    return f'<origin xyz="{xyz}" rpy="{rpy}"/>'


def _limits(model):
    if model is None:
        return np.tile([-2 * np.pi, 2 * np.pi], (6, 1)), np.full(6, np.pi)
    try:
        robot = robots.get(model)
    except CalibrationError:
        return np.tile([-2 * np.pi, 2 * np.pi], (6, 1)), np.full(6, np.pi)
    return robot.joint_limits_rad, robot.max_joint_speed_rad_s


@exporter("urdf", (".urdf",), "URDF of the calibrated arm with flange and tool frames (m, rad)")
def to_urdf(cal: Calibration) -> Exported:
    """The calibrated arm as URDF text."""
    frames, trailing = kinematics.joint_origins(cal.mdh)
    limits, speeds = _limits(cal.model)
    name = quoteattr(f"{cal.model or 'arm'}_calibrated")
    out = ['<?xml version="1.0"?>', f"<robot name={name}>"]
    out += [f'  <link name="{link}"/>' for link in LINKS + ("flange", "tool")]
    for i, origin in enumerate(frames):
        lo, hi = limits[i]
        out += [
            f'  <joint name="{JOINT_NAMES[i]}_joint" type="revolute">',
            f'    <parent link="{LINKS[i]}"/>',
            f'    <child link="{LINKS[i + 1]}"/>',
            f"    {_origin(origin)}",
            '    <axis xyz="0 0 1"/>',
            f'    <limit lower="{float(lo)!r}" upper="{float(hi)!r}" '
            f'effort="150.0" velocity="{float(speeds[i])!r}"/>',
            "  </joint>",
        ]
    for parent, child, transform in (
        ("wrist_3_link", "flange", trailing),
        ("flange", "tool", cal.flange2tool),
    ):
        out += [
            f'  <joint name="{parent}-{child}" type="fixed">',
            f'    <parent link="{parent}"/>',
            f'    <child link="{child}"/>',
            f"    {_origin(transform)}",
            "  </joint>",
        ]
    out.append("</robot>")
    return Exported("\n".join(out) + "\n")


def like(
    cal: Calibration,
    path: str | os.PathLike[str],
    base_link: str | None = None,
    tip_link: str | None = None,
) -> Exported:
    """The user's own URDF with only the chain's joint origins calibrated.

    Every moving joint's ``<origin>`` between ``base_link`` and ``tip_link``
    and the first fixed joint after joint 6 (the flange; where the tip is
    joint 6's own link, joint 6's origin holds it) take the calibrated
    kinematics (an origin the calibration leaves where it was keeps its
    text); every other byte of the file is kept. For URDF angles ``q``
    the written chain gives ``base_offset . A_1...A_6(to_model(q)) .
    flange_offset`` with the calibrated table: each link keeps its place
    relative to the joint axis it turns about (meshes, inertias and limits
    ride along unchanged). The calibration's tool and base placement are not
    part of a URDF and are not written.

    Parameters
    ----------
    cal : Calibration
        Identified against this URDF's chain (``--model arm.urdf``).
    path : str or path-like
        The URDF the calibration's nominal model came from.
    base_link, tip_link : str, optional
        As for :func:`calibrator.robots.urdf.read_chain`.

    Raises
    ------
    CalibrationError
        The calibration was not made against this chain.
    """
    from calibrator.model import kinematics
    from calibrator.robots import urdf as robot_urdf

    chain = robot_urdf.read_chain(path, base_link, tip_link)
    kin = robot_urdf.kinematics_of(chain)
    gap = float(np.abs(np.asarray(cal.nominal_mdh) - kin.mdh).max())
    if gap > 1e-6:
        raise CalibrationError(
            f"{path}: the calibration's nominal model is not this URDF's chain "
            f"({chain.base_link} to {chain.tip_link}; tables differ by {gap:.3g}); "
            f"it was made for {cal.model!r}"
        )
    nominal = kin.base_offset @ kinematics.chain(kin.mdh, np.zeros(6), all_frames=True)[1][0]
    fitted = kin.base_offset @ kinematics.chain(cal.mdh, np.zeros(6), all_frames=True)[1][0]
    frames = chain.link_frames()
    moved = {chain.base_link: np.eye(4)}  # calibrated link frames at the zero pose
    changed: dict[str, np.ndarray] = {}
    fixed_after = [j for j in chain.joints[chain.joints.index(chain.moving[5]) + 1 :]]
    rest = np.eye(4)
    for joint in fixed_after[1:]:
        rest = rest @ joint.origin
    tip = kin.base_offset @ kinematics.chain(cal.mdh, np.zeros(6))[0] @ kin.flange_offset
    index = 0
    for joint in chain.joints:
        parent = moved[joint.parent]
        if joint is chain.moving[5] and not fixed_after:
            # The tip is joint 6's own link (a URDF ending at link_6 or link_t): its
            # origin holds the flange too. Exact: the link's origin is on axis 6, so
            # link 6's own offset and turn about the axis commute with the joint's turn.
            changed[joint.name] = np.linalg.inv(parent) @ tip
            moved[joint.child] = tip
        elif joint.kind in ("revolute", "continuous"):
            # The link keeps its place relative to the axis it turns about.
            keep = np.linalg.inv(nominal[index]) @ frames[joint.child]
            target = fitted[index] @ keep
            changed[joint.name] = np.linalg.inv(parent) @ target
            moved[joint.child] = target
            index += 1
        elif fixed_after and joint is fixed_after[0]:
            changed[joint.name] = np.linalg.inv(parent) @ tip @ np.linalg.inv(rest)
            moved[joint.child] = parent @ changed[joint.name]
        else:
            moved[joint.child] = parent @ joint.origin
    text = chain.path.read_text(encoding="utf-8")
    given = {joint.name: joint.origin for joint in chain.joints}
    for name, transform in changed.items():
        # An origin the calibration left as it was keeps its own text.
        if np.abs(transform - given[name]).max() > 1e-12:
            text = _set_origin(text, name, transform, path)
    return Exported(text)


def _origin_attributes(transform: np.ndarray) -> dict[str, str]:
    values = xyz_rpy(transform)
    values[:3] /= _M
    return {
        "xyz": " ".join(repr(float(v)) for v in values[:3]),
        "rpy": " ".join(repr(float(v)) for v in values[3:]),
    }


def _quoted(value: str):
    """A ``re.sub`` replacement keeping the attribute's name and quotes, with ``value``."""

    def replace(match: re.Match[str]) -> str:
        return f"{match.group(1)}{match.group(2)}{value}{match.group(2)}"

    return replace


def _set_origin(text: str, joint: str, transform: np.ndarray, path: object) -> str:
    """``text`` with the ``<origin>`` of one joint element rewritten, nothing else."""
    start_tag = re.compile(r"<joint\b[^>]*?\bname\s*=\s*([\"'])" + re.escape(joint) + r"\1[^>]*>")
    found = list(start_tag.finditer(text))
    if len(found) != 1:
        raise CalibrationError(f"{path}: cannot find joint {joint!r} once in the text")
    head = found[0]
    end = text.find("</joint>", head.end())
    body = text[head.end() : end]
    attrs = _origin_attributes(transform)
    origin = re.search(r"<origin\b[^>]*?/?>", body)
    if origin is None:
        # No <origin>: the identity; add one right after the start tag.
        new = f'<origin xyz="{attrs["xyz"]}" rpy="{attrs["rpy"]}"/>'
        return text[: head.end()] + new + text[head.end() :]
    tag = origin.group(0)
    for key, value in attrs.items():
        pattern = re.compile(r"(\b" + key + r"\s*=\s*)([\"'])[^\"']*\2")
        if pattern.search(tag):
            tag = pattern.sub(_quoted(value), tag, 1)
        else:
            tag = tag.replace("<origin", f'<origin {key}="{value}"', 1)
    at = head.end() + origin.start()
    return text[:at] + tag + text[at + len(origin.group(0)) :]
