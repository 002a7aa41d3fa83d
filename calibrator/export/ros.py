"""``ros-kinematics``: the kinematics parameters YAML that UR's ROS description reads.

Per joint (``shoulder, upper_arm, forearm, wrist_1, wrist_2, wrist_3``) the
joint origin relative to the previous joint's frame, ``x y z`` (metres) and
``roll pitch yaw`` (radians, the URDF convention ``Rz(yaw) Ry(pitch)
Rx(roll)``), after which the joint turns about its new z axis; ``hash``
names the calibration. From an MDH table (the split ``ur_calibration``
uses)::

    origin_1 = Rz(theta_1) Tz(d_1)
    origin_i = Tx(a_{i-1}) Rx(alpha_{i-1}) Ry(beta_{i-1}) Rz(theta_i) Tz(d_i)   (i = 2..6)

so ``origin_1 Rz(q_1) ... origin_6 Rz(q_6) = A_1 ... A_6 . trailing^-1`` with
``trailing = Tx(a_6) Rx(alpha_6) Ry(beta_6)``. The file has no place for the
trailing transform (ROS puts the flange at wrist_3 with a fixed joint): the
export prints it when it is not the identity.
"""

from __future__ import annotations

import hashlib
import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from calibrator.errors import CalibrationError
from calibrator.export.registry import Exported, exporter
from calibrator.inputs import textfile, yamlfile
from calibrator.model import conventions, kinematics
from calibrator.model.frames import from_xyz_rpy, xyz_rpy

if TYPE_CHECKING:
    from calibrator.calibration import Calibration


JOINTS = ("shoulder", "upper_arm", "forearm", "wrist_1", "wrist_2", "wrist_3")
KEYS = ("x", "y", "z", "roll", "pitch", "yaw")
_M = 1000.0
#: Refuse kinematics YAML files larger than this: one is about a kilobyte.
MAX_BYTES = 2**20


def trailing_notes(trailing: np.ndarray, fmt: str) -> list[str]:
    """The residual line of a format that cannot hold ``a6, alpha6, beta6``."""
    mm, rad = conventions.residual_size(trailing)
    if mm < 1e-9 and rad < 1e-12:
        return []
    return [
        f"{fmt} cannot hold a6, alpha6, beta6: the flange is {mm:.6g} mm and {rad:.6g} rad "
        "from the wrist_3 frame (add it to the tool)"
    ]


@exporter("ros-kinematics", (".yaml", ".yml"), "ur_description kinematics parameters (m, rad)")
def to_ros(cal: Calibration) -> Exported:
    """The calibrated arm as a ``kinematics:`` YAML with its ``hash``."""
    frames, trailing = kinematics.joint_origins(cal.mdh)
    lines = ["kinematics:"]
    for name, origin in zip(JOINTS, frames, strict=True):
        values = xyz_rpy(origin)
        values[:3] /= _M
        lines.append(f"  {name}:")
        lines += [f"    {k}: {float(v)!r}" for k, v in zip(KEYS, values, strict=True)]
    digest = hashlib.sha256("\n".join(lines).encode()).digest()
    lines.append(f"  hash: calib_{int.from_bytes(digest[:8], 'big') >> 1}")
    return Exported("\n".join(lines) + "\n", trailing_notes(trailing, "ros-kinematics"))


def read(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Joint frames at the zero pose from a kinematics YAML.

    Returns
    -------
    joints : ndarray, shape (6, 4, 4)
        Frame of each joint (z = its axis) in the file's base frame (mm).
    flange : ndarray, shape (4, 4)
        The wrist_3 frame at the zero pose (mm).

    Raises
    ------
    CalibrationError
    """
    doc = yamlfile.loads(textfile.read_text(path, MAX_BYTES, "YAML"), str(path))
    kin = doc.get("kinematics") if isinstance(doc, dict) else None
    if not isinstance(kin, dict) or not all(isinstance(kin.get(j), dict) for j in JOINTS):
        raise CalibrationError(f"{path}: no 'kinematics' with the joints {', '.join(JOINTS)}")
    joints = np.empty((6, 4, 4))
    frame = np.eye(4)
    for i, name in enumerate(JOINTS):
        raw = [kin[name].get(k) for k in KEYS]
        if not all(
            isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) for v in raw
        ):
            raise CalibrationError(
                f"{path}: kinematics.{name} needs finite numbers {', '.join(KEYS)}"
            )
        values = np.asarray(raw, dtype=float)
        values[:3] *= _M
        frame = frame @ from_xyz_rpy(values)
        joints[i] = frame
    return joints, frame.copy()
