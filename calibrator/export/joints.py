"""The names and angle convention an export gives a calibrated arm's joints.

A UR's exports keep UR's names (``shoulder_pan`` ...; the kinematics YAML's
``shoulder`` ...) and angles, which are the controller's. Any other arm's
exports name its joints as its own URDF does (the shipped KUKA's
``joint_a1`` .. ``joint_a6``), ``joint_1`` .. ``joint_6`` for an arm
described by an MDH table only, and turn each joint by the angle its URDF
and controller state (:class:`~calibrator.robots.description.JointConvention`,
``q_model = sign q + offset``): a KUKA's A1 turns the other way from the
model's joint 1, and its exports say so.

The arm's URDF and chain links come from the name the calibration records:
``arm.urdf#base:tip``, a description file (``kinematics: {urdf: ...,
tip_link: ...}``), or a shipped arm's description file.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from calibrator import robots
from calibrator.errors import CalibrationError
from calibrator.inputs import textfile, yamlfile
from calibrator.inputs.errors import StrictError
from calibrator.robots import ur as ur_family

#: UR's joint and link names (``ur_description``), the names of an unnamed arm's exports.
UR_JOINTS = ("shoulder_pan", "shoulder_lift", "elbow", "wrist_1", "wrist_2", "wrist_3")
#: The kinematics YAML's keys of a UR (``ur_description``'s ``default_kinematics.yaml``).
UR_KEYS = ("shoulder", "upper_arm", "forearm", "wrist_1", "wrist_2", "wrist_3")
UR_LINKS = ("base_link",) + tuple(f"{k}_link" for k in UR_KEYS)
#: Description files larger than this are not read for their URDF (one is a few kB).
_MAX_BYTES = 2**20


@dataclass(frozen=True)
class Chain:
    """Where an arm's URDF is and which of its links the model's chain spans.

    Attributes
    ----------
    urdf : Path
    base_link, tip_link : str or None
        None: the reader's default (:func:`calibrator.robots.urdf.read_chain`).
    """

    urdf: Path
    base_link: str | None
    tip_link: str | None


@dataclass(frozen=True)
class Joints:
    """How an export names an arm's joints and which angle each turns by.

    Attributes
    ----------
    names : tuple of 6 str
        The revolute joints' names (URDF export: with ``_joint`` appended
        when ``suffix``).
    keys : tuple of 6 str
        Their keys in a kinematics YAML.
    links : tuple of 7 str
        The base link and each joint's child link.
    suffix : str
        Appended to ``names`` in a URDF (UR's ``shoulder_pan_joint``).
    sign, offset_rad : ndarray, shape (6,)
        The written angle ``q`` of each joint: ``q_model = sign q + offset``
        (rad); couplings between joints are not part of it (``couplings``).
    couplings : tuple of (int, int, float)
        The controller's ties no export can hold (0-based ``(joint, earlier, factor)``).
    limits_rad : ndarray, shape (6, 2)
        Joint limits of the written angles (rad).
    speeds_rad_s : ndarray, shape (6,)
    """

    names: tuple[str, ...]
    keys: tuple[str, ...]
    links: tuple[str, ...]
    suffix: str
    sign: np.ndarray
    offset_rad: np.ndarray
    couplings: tuple[tuple[int, int, float], ...]
    limits_rad: np.ndarray
    speeds_rad_s: np.ndarray

    def coupling_notes(self, fmt: str) -> list[str]:
        """One line per controller coupling ``fmt`` cannot hold."""
        return [
            f"{fmt} cannot hold the controller's coupling of {self.names[j]} to "
            f"{self.names[k]} (factor {f:g}): {self.names[j]} turns by the controller's "
            f"angle plus {f:g} x {self.names[k]}'s (as the ROS driver states it)"
            for j, k, f in self.couplings
        ]


def of(model: str | None) -> Joints:
    """How the exports of a calibration of ``model`` name and turn its joints.

    Parameters
    ----------
    model : str or None
        The calibration's ``model``; None or a name no description has gives
        UR's names, the model's own angles and +-2 pi limits at pi rad/s.
    """
    arm = _arm(model)
    if arm is None:
        return Joints(
            UR_JOINTS,
            UR_KEYS,
            UR_LINKS,
            "_joint",
            np.ones(6),
            np.zeros(6),
            (),
            np.tile([-2 * np.pi, 2 * np.pi], (6, 1)),
            np.full(6, np.pi),
        )
    convention = arm.convention
    sign, offset = np.asarray(convention.sign), np.asarray(convention.offset_rad)
    # The written angle q = sign (q_model - offset): a limit's ends map one to one.
    limits = np.sort((arm.joint_limits_rad - offset[:, None]) * sign[:, None], axis=1)
    speeds = np.asarray(arm.max_joint_speed_rad_s)
    common = (sign, offset, tuple(convention.couplings), limits, speeds)
    if arm.family == ur_family.FAMILY:
        return Joints(UR_JOINTS, UR_KEYS, UR_LINKS, "_joint", *common)
    named = _urdf_names(model)
    if named is None:
        names = tuple(f"joint_{i}" for i in range(1, 7))
        return Joints(names, names, ("base_link",) + tuple(f"link_{i}" for i in range(1, 7)), "",
                      *common)  # fmt: skip
    joints, links = named
    return Joints(joints, joints, links, "", *common)


def chain_of(model: str | None) -> Chain | None:
    """The URDF and chain links of the arm named ``model``; None for an arm without one.

    ``model`` is a calibration's record: ``arm.urdf`` or ``arm.urdf#base:tip``,
    a description file's path, or a shipped arm's name (its description file
    names its URDF and, where the default would be wrong, the links).
    """
    if model is None:
        return None
    path, _, links = str(model).strip().partition("#")
    if path.lower().endswith(".urdf"):
        base, _, tip = links.partition(":")
        return Chain(Path(path), base or None, tip or None)
    description = _description_file(path)
    if description is None:
        return None
    try:
        doc = yamlfile.loads(
            textfile.read_text(description, _MAX_BYTES, "a robot description"), str(description)
        )
    except (StrictError, CalibrationError, OSError):
        return None
    kin = doc.get("kinematics") if isinstance(doc, dict) else None
    if not isinstance(kin, dict) or not isinstance(kin.get("urdf"), str):
        return None

    def link(key: str) -> str | None:
        value = kin.get(key)
        return value if isinstance(value, str) else None

    return Chain(description.parent / kin["urdf"], link("base_link"), link("tip_link"))


def _description_file(name: str) -> Path | None:
    """The description file of a shipped arm's name, or ``name`` itself if it is one."""
    if name.lower().endswith((".yaml", ".yml")):
        return Path(name)
    from calibrator.robots import shipped

    key = name.lower()
    return shipped.DATA / f"{key}.yaml" if key in shipped.DESCRIPTIONS else None


def _arm(model: str | None) -> robots.RobotDescription | None:
    if model is None:
        return None
    try:
        return robots.get(model)
    except CalibrationError:
        return None


def _urdf_names(model: str | None) -> tuple[tuple[str, ...], tuple[str, ...]] | None:
    """The six moving joints' names and the chain's links of ``model``'s URDF, or None."""
    from calibrator.robots import urdf

    chain = chain_of(model)
    if chain is None:
        return None
    try:
        read = urdf.read_chain(chain.urdf, chain.base_link, chain.tip_link)
    except CalibrationError:
        return None
    moving = read.moving
    if len(moving) != 6:
        return None
    return tuple(j.name for j in moving), (moving[0].parent,) + tuple(j.child for j in moving)
