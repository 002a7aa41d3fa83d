"""``ros-kinematics``: the kinematics parameters YAML that UR's ROS description reads.

Per joint (``shoulder, upper_arm, forearm, wrist_1, wrist_2, wrist_3``;
another arm's: its URDF's joint names, :mod:`calibrator.export.joints`) the
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
from calibrator.export import joints as arm_joints
from calibrator.export.registry import Exported, exporter
from calibrator.inputs import textfile, yamlfile
from calibrator.model import conventions, kinematics
from calibrator.model.frames import from_xyz_rpy, xyz_rpy

if TYPE_CHECKING:
    from calibrator.calibration import Calibration


#: The keys of UR's file (the ones :func:`read` reads).
JOINTS = arm_joints.UR_KEYS
KEYS = ("x", "y", "z", "roll", "pitch", "yaw")
_M = 1000.0
#: Refuse kinematics YAML files larger than this: one is about a kilobyte.
MAX_BYTES = 2**20


def trailing_notes(trailing: np.ndarray, fmt: str, last: str = "wrist_3") -> list[str]:
    """The residual line of a format that cannot hold ``a6, alpha6, beta6``."""
    mm, rad = conventions.residual_size(trailing)
    if mm < 1e-9 and rad < 1e-12:
        return []
    return [
        f"{fmt} cannot hold a6, alpha6, beta6: the flange is {mm:.6g} mm and {rad:.6g} rad "
        f"from the {last} frame (add it to the tool)"
    ]


def controller_origins(
    origins: np.ndarray, trailing: np.ndarray, arm: arm_joints.Joints
) -> tuple[np.ndarray, np.ndarray]:
    """Joint origins after which each joint turns about its z by the controller's angle.

    With ``q_model = sign q + offset``, ``Rz(q_model) = Rz(offset) F Rz(q) F^-1``
    where ``F`` is ``Rx(pi)`` for a joint whose angle is the model's negative
    (else the identity): origin ``i`` becomes ``F_{i-1}^-1 origin_i Rz(offset_i) F_i``
    and the trailing transform ``F_6^-1 trailing``. Unchanged (the same
    numbers) for a joint the controller turns as the model does.

    Parameters
    ----------
    origins : ndarray, shape (6, 4, 4)
        :func:`calibrator.model.kinematics.joint_origins` (mm).
    trailing : ndarray, shape (4, 4)
    arm : calibrator.export.joints.Joints

    Returns
    -------
    origins : ndarray, shape (6, 4, 4)
    trailing : ndarray, shape (4, 4)
    """
    flip = np.diag([1.0, -1.0, -1.0, 1.0])  # Rx(pi), its own inverse
    out = np.array(origins, dtype=float)
    before = False  # the previous joint's frame was flipped
    for i in range(6):
        if before:
            out[i] = flip @ out[i]
        if arm.offset_rad[i]:
            c, s = np.cos(arm.offset_rad[i]), np.sin(arm.offset_rad[i])
            spin = np.eye(4)
            spin[:2, :2] = [[c, -s], [s, c]]
            out[i] = out[i] @ spin
        before = bool(arm.sign[i] < 0)
        if before:
            out[i] = out[i] @ flip
    return out, (flip @ trailing if before else trailing)


@exporter("ros-kinematics", (".yaml", ".yml"), "ur_description kinematics parameters (m, rad)")
def to_ros(cal: Calibration) -> Exported:
    """The calibrated arm as a ``kinematics:`` YAML with its ``hash``.

    A UR's keys are ``ur_description``'s; another arm's are its URDF's joint
    names, each joint turning by its controller's angle
    (:func:`controller_origins`; :mod:`calibrator.export.joints`).
    """
    arm = arm_joints.of(cal.model)
    frames, trailing = controller_origins(*kinematics.joint_origins(cal.mdh), arm)
    lines = ["kinematics:"]
    for name, origin in zip(arm.keys, frames, strict=True):
        values = xyz_rpy(origin)
        values[:3] /= _M
        lines.append(f"  {name}:")
        lines += [f"    {k}: {float(v)!r}" for k, v in zip(KEYS, values, strict=True)]
    digest = hashlib.sha256("\n".join(lines).encode()).digest()
    lines.append(f"  hash: calib_{int.from_bytes(digest[:8], 'big') >> 1}")
    notes = trailing_notes(trailing, "ros-kinematics", arm.keys[5])
    return Exported("\n".join(lines) + "\n", notes + arm.coupling_notes("ros-kinematics"))


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
