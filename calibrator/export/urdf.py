"""``urdf``: a URDF of the calibrated arm (metres, radians).

Links ``base_link``, ``shoulder_link`` ... ``wrist_3_link`` as in UR's
description (another arm's: its own URDF's names, :mod:`calibrator.export.joints`),
then fixed joints to ``flange`` (the MDH flange frame, holding ``a6, alpha6,
beta6`` that the kinematics YAML cannot) and ``tool`` (the identified
``flange2tool``). The joint origins are those of
:func:`calibrator.model.kinematics.joint_origins`, each joint turning by the
angle its controller states: about ``-z`` where that angle is the model's
negative (a KUKA's A1 and A6), from an origin turned by the convention's
zero offset. Nothing is lost: the chain ``base_link -> flange`` is the
calibrated ``A_1 ... A_6``.
"""

from __future__ import annotations

import os
import re
from typing import TYPE_CHECKING, Any
from xml.sax.saxutils import quoteattr

import numpy as np

from calibrator.errors import CalibrationError
from calibrator.export import joints as arm_joints
from calibrator.export.registry import Exported, exporter
from calibrator.model import kinematics
from calibrator.model.frames import xyz_rpy

if TYPE_CHECKING:
    from calibrator.calibration import Calibration


_M = 1000.0
#: UR's names, as every UR export writes them.
JOINT_NAMES = arm_joints.UR_JOINTS
LINKS = arm_joints.UR_LINKS


def _origin(transform):
    values = xyz_rpy(transform)
    values[:3] /= _M
    xyz = " ".join(repr(float(v)) for v in values[:3])
    rpy = " ".join(repr(float(v)) for v in values[3:])
    return f'<origin xyz="{xyz}" rpy="{rpy}"/>'


def _spin(angle: float) -> np.ndarray:
    """``Rz(angle)`` as a (4, 4) transform."""
    c, s = np.cos(angle), np.sin(angle)
    out = np.eye(4)
    out[:2, :2] = [[c, -s], [s, c]]
    return out


@exporter("urdf", (".urdf",), "URDF of the calibrated arm with flange and tool frames (m, rad)")
def to_urdf(cal: Calibration) -> Exported:
    """The calibrated arm as URDF text, its joints named and turning as its controller's."""
    frames, trailing = kinematics.joint_origins(cal.mdh)
    arm = arm_joints.of(cal.model)
    links = arm.links
    name = quoteattr(f"{cal.model or 'arm'}_calibrated")
    out = ['<?xml version="1.0"?>', f"<robot name={name}>"]
    out += [f'  <link name="{link}"/>' for link in links + ("flange", "tool")]
    for i, origin in enumerate(frames):
        lo, hi = arm.limits_rad[i]
        # q_model = sign q + offset: Rz(q_model) = Rz(offset) . (a turn by q about sign z).
        if arm.offset_rad[i]:
            origin = origin @ _spin(float(arm.offset_rad[i]))
        axis = "0 0 1" if arm.sign[i] > 0 else "0 0 -1"
        out += [
            f'  <joint name="{arm.names[i]}{arm.suffix}" type="revolute">',
            f'    <parent link="{links[i]}"/>',
            f'    <child link="{links[i + 1]}"/>',
            f"    {_origin(origin)}",
            f'    <axis xyz="{axis}"/>',
            f'    <limit lower="{float(lo)!r}" upper="{float(hi)!r}" '
            f'effort="150.0" velocity="{float(arm.speeds_rad_s[i])!r}"/>',
            "  </joint>",
        ]
    for parent, child, transform in (
        (links[6], "flange", trailing),
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
    return Exported("\n".join(out) + "\n", arm.coupling_notes("urdf"))


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
        As for :func:`calibrator.robots.urdf.read_chain`; a link not given is
        the one the calibration's arm names (a shipped arm's description
        file's ``tip_link: flange``, ``arm.urdf#base:tip``) where ``path``
        has it, else the reader's default.

    Raises
    ------
    CalibrationError
        The calibration was not made against this chain.
    """
    from calibrator.model import kinematics

    chain, kin = _chain_like(cal, path, base_link, tip_link)
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


def _chain_like(
    cal: Calibration,
    path: str | os.PathLike[str],
    base_link: str | None,
    tip_link: str | None,
) -> tuple[Any, Any]:
    """The chain of ``path`` the calibration was made against, and its kinematics.

    The links given win; the others are first the ones the calibration's arm
    records (its URDF's chain), then the reader's defaults: the first
    whose table is the calibration's nominal one is taken.
    """
    from calibrator.robots import urdf as robot_urdf

    tried: list[tuple[str | None, str | None]] = []
    recorded = arm_joints.chain_of(cal.model)
    if recorded is not None:
        tried.append((base_link or recorded.base_link, tip_link or recorded.tip_link))
    tried.append((base_link, tip_link))
    first: tuple[Any, float] | None = None
    for base, tip in dict.fromkeys(tried):
        try:
            chain = robot_urdf.read_chain(path, base, tip)
        except CalibrationError:
            if (base, tip) == (base_link, tip_link) and first is None:
                raise  # the links as given (or the defaults) are not in the file
            continue  # the arm's links are not this file's: try the given ones
        kin = robot_urdf.kinematics_of(chain)
        gap = float(np.abs(np.asarray(cal.nominal_mdh) - kin.mdh).max())
        if gap <= 1e-6:
            return chain, kin
        if first is None:
            first = (chain, gap)
    assert first is not None
    chain, gap = first
    raise CalibrationError(
        f"{path}: the calibration's nominal model is not this URDF's chain "
        f"({chain.base_link} to {chain.tip_link}; tables differ by {gap:.3g}); "
        f"it was made for {cal.model!r}"
    )


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
