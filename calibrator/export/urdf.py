"""``urdf``: a URDF of the calibrated arm (metres, radians).

Links ``base_link``, ``shoulder_link`` ... ``wrist_3_link`` as in UR's
description, then fixed joints to ``flange`` (the MDH flange frame, holding
``a6, alpha6, beta6`` that the kinematics YAML cannot) and ``tool`` (the
identified ``flange2tool``). The joint origins are those of
:func:`calibrator.export.ros.origins`. Nothing is lost: the chain
``base_link -> flange`` is the calibrated ``A_1 ... A_6``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING
from xml.sax.saxutils import quoteattr

import numpy as np

from calibrator.errors import CalibrationError
from calibrator.export import Exported, exporter
from calibrator.export.ros import JOINTS, origin_values, origins
from calibrator.models import get_model

if TYPE_CHECKING:
    from calibrator.calibration import Calibration


_M = 1000.0
JOINT_NAMES = ("shoulder_pan", "shoulder_lift", "elbow", "wrist_1", "wrist_2", "wrist_3")
LINKS = ("base_link",) + tuple(f"{j}_link" for j in JOINTS)


def _origin(transform):
    values = origin_values(transform)
    values[:3] /= _M
    xyz = " ".join(repr(float(v)) for v in values[:3])
    rpy = " ".join(repr(float(v)) for v in values[3:])
    return f'<origin xyz="{xyz}" rpy="{rpy}"/>'


def _limits(model):
    if model is None:
        return np.tile([-2 * np.pi, 2 * np.pi], (6, 1)), np.full(6, np.pi)
    try:
        robot = get_model(model)
    except CalibrationError:
        return np.tile([-2 * np.pi, 2 * np.pi], (6, 1)), np.full(6, np.pi)
    return robot.joint_limits_rad, robot.max_joint_speed_rad_s


@exporter("urdf", (".urdf",), "URDF of the calibrated arm with flange and tool frames (m, rad)")
def to_urdf(cal: Calibration) -> Exported:
    """The calibrated arm as URDF text."""
    frames, trailing = origins(cal.mdh)
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
