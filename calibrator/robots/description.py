"""What one arm is: :class:`RobotDescription`, the one home of an arm's data.

A description holds everything the commands need to know about an arm: its
nominal kinematics (an MDH table, :mod:`calibrator.model.kinematics`, with the base
and flange offsets a table cannot hold), its joint limits and the motion
ceilings derived from them, masses and centres of mass, the capsule body of
the collision checks, named configurations, the controller's joint
convention and its family (what family-specific exporters such as UR's
calibration form need). Code reads these attributes; it never switches on an
arm's name.

Frames and units: mm and rad; link ``i`` (1..6) is frame ``i`` of
:func:`calibrator.model.kinematics.chain` (the end of ``A_1 ... A_i``), link 0 the
robot base frame (MDH frame 0).

Motion ceilings
---------------
Every arm carries a fixed ceiling on the speed (1.0 rad/s) and acceleration
(2.0 rad/s^2, or the lowest published acceleration limit if lower) of the
moves a calibration run commands. They sit well below the data sheets (UR's
slowest joints turn at 2.09 rad/s; URScript's default ``movej`` acceleration
is 1.4 rad/s^2 and ur-rtde accepts up to 40), because a calibration run gains
nothing from fast moves and a tracker cell is crowded. Options such as
``--speed``, ``--accel`` and ``--max-speed`` can only lower them.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from calibrator.errors import CalibrationError
from calibrator.model import frames

#: Fixed ceiling on the leading-joint speed of any move a calibration run
#: commands (rad/s).
MOVE_SPEED_CAP_RAD_S = 1.0
#: Fixed ceiling on the leading-joint acceleration of any move (rad/s^2);
#: lowered to the lowest published acceleration limit if that is lower.
MOVE_ACCEL_CAP_RAD_S2 = 2.0
#: Name and version of the description format (:mod:`calibrator.robots.files`).
FORMAT = "calibrator-robot/1"


class DescriptionError(CalibrationError):
    """A robot description is unknown, unreadable or describes an arm we cannot handle."""


@dataclass(frozen=True)
class Capsule:
    """A segment ``p``-``q`` with a radius, fixed in the frame of one link.

    Attributes
    ----------
    name : str
        What it is ("upper arm", "wrist 2", ...), used in messages.
    link : int
        Link it belongs to: 0 base, 1..6 the links (frame i of
        :func:`calibrator.model.kinematics.chain`), 7 the tool (on the flange).
    p_mm, q_mm : tuple of 3 float
        End points in the link's frame, mm.
    radius_mm : float
    """

    name: str
    link: int
    p_mm: tuple[float, float, float]
    q_mm: tuple[float, float, float]
    radius_mm: float

    def __post_init__(self) -> None:
        # A capsule of no or negative radius encloses nothing: every clearance
        # check against it would pass.
        if not (np.isfinite(self.radius_mm) and self.radius_mm > 0):
            raise DescriptionError(
                f"capsule {self.name!r}: radius {self.radius_mm:g} mm must be > 0"
            )
        if not np.all(np.isfinite([*self.p_mm, *self.q_mm])):
            raise DescriptionError(f"capsule {self.name!r}: its end points must be finite")
        if self.link not in range(0, 8):
            raise DescriptionError(f"capsule {self.name!r}: link {self.link} is not 0 to 7")


@dataclass(frozen=True)
class Body:
    """The arm as capsules, and the base it stands on.

    Attributes
    ----------
    capsules : tuple of Capsule
        Links 1..6 (no tool: the cell adds the tool's capsule).
    base_radius_mm : float
        Base cylinder about the base z axis, from the mounting plane up to ``base_top_mm``.
    base_top_mm : float
        Top of the base cylinder (joint 1's housing included), base frame z, mm.
    mount_z_mm : float
        The mounting plane's z in the base frame, mm.
    shoulder_mm : tuple of 3 float
        Centre of the reach envelope (on the base axis), base frame, mm.
    margin_mm : float
        Margin already added to every radius (stated, for fitted bodies).
    source : str
        Where the radii come from.
    guessed : str
        What of the body is guessed rather than fitted to the arm's geometry
        (a URDF's links drawn as capsules along the joints: its collision
        meshes not found, or none given), said by ``plan`` and ``measure``;
        empty when nothing is. Not part of the digest: ``source`` says it too.
    """

    capsules: tuple[Capsule, ...]
    base_radius_mm: float
    base_top_mm: float
    mount_z_mm: float
    shoulder_mm: tuple[float, float, float]
    margin_mm: float = 0.0
    source: str = ""
    guessed: str = ""

    def __post_init__(self) -> None:
        if not (np.isfinite(self.base_radius_mm) and self.base_radius_mm > 0):
            raise DescriptionError(f"body: base radius {self.base_radius_mm:g} mm must be > 0")
        if not (np.isfinite(self.margin_mm) and self.margin_mm >= 0):
            raise DescriptionError(f"body: margin {self.margin_mm:g} mm must be >= 0")
        if not np.all(np.isfinite([self.base_top_mm, self.mount_z_mm, *self.shoulder_mm])):
            raise DescriptionError("body: base top, mounting plane and shoulder must be finite")


@dataclass(frozen=True)
class JointConvention:
    """Angles the controller shows and programs use, against the model's angles.

    ``q_model[j] = sign[j] * q_ctrl[j] + offset_rad[j] + sum(f * q_ctrl[k])``
    over the couplings ``(j, k, f)`` of joint ``j`` with an earlier joint
    ``k < j`` (Fanuc's J2/J3 interaction: ``(2, 1, f)`` with 0-based
    indices). Lower-triangular, so it inverts by forward substitution.

    Attributes
    ----------
    sign : tuple of 6 float
        +1 or -1 per joint.
    offset_rad : tuple of 6 float
        Model angle when the controller shows zero (uncoupled part), rad.
    couplings : tuple of (int, int, float)
        ``(joint, earlier joint, factor)``, 0-based joint indices.
    source : str
        Where the convention comes from.
    """

    sign: tuple[float, ...] = (1.0,) * 6
    offset_rad: tuple[float, ...] = (0.0,) * 6
    couplings: tuple[tuple[int, int, float], ...] = ()
    source: str = "the model's own angles"

    def __post_init__(self) -> None:
        if len(self.sign) != 6 or any(s not in (1.0, -1.0) for s in self.sign):
            raise DescriptionError("joint convention: sign must be six values of +1 or -1")
        if len(self.offset_rad) != 6 or not np.all(np.isfinite(self.offset_rad)):
            raise DescriptionError("joint convention: offset_rad must be six finite angles")
        for j, k, f in self.couplings:
            if not (0 <= k < j < 6) or not np.isfinite(f):
                raise DescriptionError(
                    f"joint convention: coupling ({j}, {k}, {f}) must tie a joint to an "
                    "earlier one (0-based, k < j) with a finite factor"
                )

    def to_model(self, q_ctrl: ArrayLike) -> np.ndarray:
        """Model angles of controller angles, shape (..., 6) -> (..., 6), rad."""
        q = np.asarray(q_ctrl, dtype=float)
        out = q * np.asarray(self.sign) + np.asarray(self.offset_rad)
        for j, k, f in self.couplings:
            out[..., j] += f * q[..., k]
        return out

    def to_controller(self, q_model: ArrayLike) -> np.ndarray:
        """Controller angles of model angles (inverse of :meth:`to_model`), rad."""
        q = np.asarray(q_model, dtype=float)
        out = (q - np.asarray(self.offset_rad)) * np.asarray(self.sign)
        # Couplings refer to earlier joints only: those are final when joint j is reached.
        for j in range(6):
            ties = [(k, f) for jj, k, f in self.couplings if jj == j]
            if ties:
                rest = q[..., j] - self.offset_rad[j]
                for k, f in ties:
                    rest = rest - f * out[..., k]
                out[..., j] = rest * self.sign[j]
        return out

    def model_box(self, controller_limits_rad: ArrayLike) -> np.ndarray:
        """The smallest box of model angles holding a box of controller angles, rad.

        Parameters
        ----------
        controller_limits_rad : array_like, shape (6, 2)
            ``[min, max]`` per joint as the controller states them.

        Returns
        -------
        ndarray, shape (6, 2)
            ``[min, max]`` of each model angle over that box (exact for signs and
            offsets; through a coupling, every model angle some controller box
            point gives, and more).
        """
        box = np.asarray(controller_limits_rad, dtype=float)
        ends = np.sort(box * np.asarray(self.sign)[:, None], axis=1)
        ends += np.asarray(self.offset_rad)[:, None]
        for j, k, f in self.couplings:
            ends[j] += np.sort(f * box[k])
        return ends

    @property
    def is_identity(self) -> bool:
        """Whether controller and model angles are the same."""
        return all(s == 1.0 for s in self.sign) and not any(self.offset_rad) and not self.couplings


def rigid(t: np.ndarray, what: str) -> None:
    """Refuse a (4, 4) that is not a rigid transform (rotation and translation only).

    A scaled or sheared offset would make every pose computed through it
    wrong while each check of the arm still passed.
    """
    r = t[:3, :3]
    if not (
        np.allclose(t[3], [0.0, 0.0, 0.0, 1.0], atol=1e-9)
        and np.allclose(r.T @ r, np.eye(3), atol=1e-6)
        and np.linalg.det(r) > 0
    ):
        raise DescriptionError(
            f"{what} must be a rigid transform (an orthonormal rotation with det +1, "
            "last row 0 0 0 1)"
        )


def _frozen(value: ArrayLike, shape: tuple[int, ...], what: str, name: str) -> np.ndarray:
    array = np.array(value, dtype=float)
    if array.shape != shape or not np.all(np.isfinite(array)):
        raise DescriptionError(f"robot {name}: {what} must be finite, shape {shape}")
    array.setflags(write=False)
    return array


def _rigid(value: ArrayLike, what: str, name: str) -> np.ndarray:
    """A frozen (4, 4) rigid transform (:func:`rigid`), or one line naming what is wrong."""
    array = _frozen(value, (4, 4), what, name)
    rigid(array, f"robot {name}: {what}")
    return array


@dataclass(frozen=True)
class RobotDescription:
    """One arm, as data.

    Attributes
    ----------
    name : str
        Lower-case name (``ur10e``, ``kuka-kr6-r900``, or a file's name).
    mdh : ndarray, shape (6, 5)
        Nominal MDH table (mm, rad).
    joint_limits_rad : ndarray, shape (6, 2)
        ``[min, max]`` model joint angle per joint (rad).
    max_joint_speed_rad_s : ndarray, shape (6,)
        Joint speed limits (rad/s).
    family : str
        What family-specific code needs to know (``"ur"`` for arms whose
        controller keeps UR's DH deltas; ``"generic"`` otherwise).
    max_joint_accel_rad_s2 : ndarray, shape (6,) or None
        Joint acceleration limits where published (rad/s^2).
    body : Body or None
        Capsules for the collision checks (None: the cell cannot check this arm).
    configurations : mapping of str to tuple of 6 float
        Named model joint vectors (rad): at least ``home``; ``upright``
        (joints 2, 3 hold the arm straight up; joints 4, 5 point the flange
        straight up: turning joints 1 and 6 there sweeps nothing into the arm).
    mass_kg : ndarray, shape (6,) or None
        Link masses, where known.
    com_mm : ndarray, shape (6, 3) or None
        Centre of mass of link ``i`` in link frame ``i`` (mm), where known.
    convention : JointConvention
        The controller's joint angles against the model's.
    base_offset : ndarray, shape (4, 4)
        MDH frame 0 in the description's own base frame (a URDF's base
        link); identity for tables given as MDH.
    flange_offset : ndarray, shape (4, 4)
        The description's flange (a URDF's tip link) in the MDH flange frame.
    reference_errors : ndarray, shape (6, 5) or None
        Published true errors of this arm (a paper's simulation table), if any.
    source : str
        Where the numbers come from.
    limit_notes : tuple of str
        Joint limits narrowed from the source's, and why (a URDF's meshes
        coming closer than the margin beyond them: :mod:`calibrator.robots.clearance`).
    controller_limits_rad : ndarray, shape (6, 2) or None
        ``[min, max]`` per joint as the controller states them, where the
        description gives them so and a coupling makes them another rule than
        :attr:`joint_limits_rad` (FANUC's J3, limited from the horizon); a joint
        vector is inside the limits when it is inside both
        (:meth:`outside_limits`). None: :attr:`joint_limits_rad` is the rule.
    base2controller_base : ndarray, shape (4, 4)
        The frame the controller calls the robot's base or world (KUKA
        ``$ROBROOT``, ABB's base frame, FANUC's World, Yaskawa's ROBOT,
        Staubli's world, UR's Base), as its pose in the description's base
        frame (the frame ``base_offset`` is given in: a URDF's base link, MDH
        frame 0 for a table), mm. Identity: the description's base frame is
        the controller's.
    flange2controller_flange : ndarray, shape (4, 4)
        The controller's flange, its tool 0 (KUKA ``$NULLFRAME`` tool, ABB
        ``tool0``, FANUC's faceplate UT 0, Yaskawa's flange, UR's tool
        flange), as its pose in the description's flange frame (a URDF's tip
        link, the MDH flange frame for a table), mm.
    controller_base_source, controller_flange_source : str
        Where each controller frame comes from ("" where it is the
        description's own frame and nobody declared it).
    """

    name: str
    mdh: np.ndarray
    joint_limits_rad: np.ndarray
    max_joint_speed_rad_s: np.ndarray
    family: str = "generic"
    body: Body | None = None
    configurations: Mapping[str, tuple[float, ...]] = field(
        default_factory=lambda: {"home": (0.0,) * 6}
    )
    max_joint_accel_rad_s2: np.ndarray | None = None
    mass_kg: np.ndarray | None = None
    com_mm: np.ndarray | None = None
    convention: JointConvention = field(default_factory=JointConvention)
    base_offset: np.ndarray = field(default_factory=lambda: np.eye(4))
    flange_offset: np.ndarray = field(default_factory=lambda: np.eye(4))
    reference_errors: np.ndarray | None = None
    source: str = ""
    limit_notes: tuple[str, ...] = ()
    controller_limits_rad: np.ndarray | None = None
    base2controller_base: np.ndarray = field(default_factory=lambda: np.eye(4))
    flange2controller_flange: np.ndarray = field(default_factory=lambda: np.eye(4))
    controller_base_source: str = ""
    controller_flange_source: str = ""

    def __post_init__(self) -> None:
        n = self.name
        put = object.__setattr__
        put(self, "mdh", _frozen(self.mdh, (6, 5), "mdh", n))
        put(self, "joint_limits_rad", _frozen(self.joint_limits_rad, (6, 2), "joint limits", n))
        if np.any(self.joint_limits_rad[:, 0] >= self.joint_limits_rad[:, 1]):
            raise DescriptionError(f"robot {n}: every joint needs min < max")
        if self.controller_limits_rad is not None:
            ctrl = _frozen(self.controller_limits_rad, (6, 2), "controller joint limits", n)
            if np.any(ctrl[:, 0] >= ctrl[:, 1]):
                raise DescriptionError(f"robot {n}: every controller joint limit needs min < max")
            put(self, "controller_limits_rad", ctrl)
        speeds = _frozen(self.max_joint_speed_rad_s, (6,), "joint speeds", n)
        if np.any(speeds <= 0):
            raise DescriptionError(f"robot {n}: joint speeds must be > 0")
        put(self, "max_joint_speed_rad_s", speeds)
        if self.max_joint_accel_rad_s2 is not None:
            accel = _frozen(self.max_joint_accel_rad_s2, (6,), "joint accelerations", n)
            if np.any(accel <= 0):
                raise DescriptionError(f"robot {n}: joint accelerations must be > 0")
            put(self, "max_joint_accel_rad_s2", accel)
        if (self.mass_kg is None) != (self.com_mm is None):
            raise DescriptionError(f"robot {n}: give masses and centres of mass together")
        if self.mass_kg is not None and self.com_mm is not None:
            put(self, "mass_kg", _frozen(self.mass_kg, (6,), "masses", n))
            put(self, "com_mm", _frozen(self.com_mm, (6, 3), "centres of mass", n))
            if np.any(self.mass_kg < 0):
                raise DescriptionError(f"robot {n}: masses must be >= 0")
        for key in (
            "base_offset",
            "flange_offset",
            "base2controller_base",
            "flange2controller_flange",
        ):
            put(self, key, _rigid(getattr(self, key), key, n))
        if self.reference_errors is not None:
            put(self, "reference_errors", _frozen(self.reference_errors, (6, 5), "errors", n))
        configs = {}
        for key, q in dict(self.configurations).items():
            configs[str(key)] = tuple(_frozen(q, (6,), f"configuration {key!r}", n).tolist())
        if "home" not in configs:
            raise DescriptionError(f"robot {n}: needs a 'home' configuration")
        lim = self.joint_limits_rad
        for key, q in configs.items():
            # A named configuration outside the limits is one no check would let the arm reach.
            out = [j for j in range(6) if not lim[j, 0] - 1e-9 <= q[j] <= lim[j, 1] + 1e-9]
            if out:
                j = out[0]
                raise DescriptionError(
                    f"robot {n}: configuration {key!r} has joint {j + 1} at "
                    f"{np.degrees(q[j]):.4g} deg, outside its limits "
                    f"[{np.degrees(lim[j, 0]):.4g}, {np.degrees(lim[j, 1]):.4g}] deg (model angles)"
                )
        put(self, "configurations", MappingProxyType(configs))

    # -- the ceilings every move obeys -------------------------------------------------

    @property
    def move_speed_cap_rad_s(self) -> float:
        """Ceiling on the leading-joint speed of any move (rad/s); options only lower it.

        Fixed: the joint speed limits bound each joint separately (a move whose
        slowest joint leads is checked against that joint's limit).
        """
        return MOVE_SPEED_CAP_RAD_S

    @property
    def move_accel_cap_rad_s2(self) -> float:
        """Ceiling on the leading-joint acceleration of any move (rad/s^2)."""
        if self.max_joint_accel_rad_s2 is None:
            return MOVE_ACCEL_CAP_RAD_S2
        return float(min(MOVE_ACCEL_CAP_RAD_S2, self.max_joint_accel_rad_s2.min()))

    # -- derived views -----------------------------------------------------------------

    def outside_limits(self, q_model: ArrayLike, tolerance_rad: float = 0.0) -> np.ndarray:
        """Which joints of model joint vectors break a limit, shape (..., 6) of bool.

        A joint breaks its limit when its model angle leaves
        :attr:`joint_limits_rad`, or, where the description states them, its
        controller angle leaves :attr:`controller_limits_rad` (NaN breaks both).

        Parameters
        ----------
        q_model : array_like, shape (..., 6)
            The model's joint angles, rad.
        tolerance_rad : float
            Allowed beyond each end, rad.
        """
        q = np.asarray(q_model, dtype=float)
        lo, hi = self.joint_limits_rad[:, 0], self.joint_limits_rad[:, 1]
        inside = (q >= lo - tolerance_rad) & (q <= hi + tolerance_rad)
        if self.controller_limits_rad is not None:
            c = self.convention.to_controller(q)
            lo, hi = self.controller_limits_rad[:, 0], self.controller_limits_rad[:, 1]
            inside &= (c >= lo - tolerance_rad) & (c <= hi + tolerance_rad)
        return ~inside

    def controller_box(self) -> np.ndarray:
        """The joint limits in the controller's angles, shape (6, 2), rad.

        The stated :attr:`controller_limits_rad`; else, joint by joint, the
        model's limits through the convention's sign and offset (exact for an
        uncoupled joint; a coupled joint's range then depends on the others,
        and its row is the model's limits, NaN-free but not a controller box).
        """
        if self.controller_limits_rad is not None:
            return np.array(self.controller_limits_rad)
        c = self.convention
        box = (self.joint_limits_rad - np.asarray(c.offset_rad)[:, None]) * np.asarray(c.sign)[
            :, None
        ]
        box = np.sort(box, axis=1)
        for j, _, _ in c.couplings:
            box[j] = self.joint_limits_rad[j]
        return box

    def limit_breach(self, q_model: ArrayLike) -> tuple[int, str] | None:
        """The first joint vector and joint outside the limits, said in the controller's angles.

        Parameters
        ----------
        q_model : array_like, shape (N, 6)
            The model's joint angles, rad.

        Returns
        -------
        (int, str) or None
            The row, and ``"joint 3: -4.13 rad outside [-3.2, 4.8]"`` as the
            controller shows it (a coupled joint without stated controller
            limits is named by its model angle, said so); None when all are inside.
        """
        q = np.atleast_2d(np.asarray(q_model, dtype=float))
        outside = self.outside_limits(q)
        if not outside.any():
            return None
        row, joint = (int(v) for v in np.argwhere(outside)[0])
        coupled = any(j == joint for j, _, _ in self.convention.couplings)
        if coupled and self.controller_limits_rad is None:
            lo, hi = self.joint_limits_rad[joint]
            return row, (
                f"joint {joint + 1}: the model's angle {q[row, joint]:.6g} rad (coupled to an "
                f"earlier joint) outside [{lo:.6g}, {hi:.6g}]"
            )
        value = self.convention.to_controller(q[row])[joint]
        lo, hi = self.controller_box()[joint]
        if lo <= value <= hi:  # inside the controller's box: the model's box breaks
            m_lo, m_hi = self.joint_limits_rad[joint]
            return row, (
                f"joint {joint + 1}: the model's angle {q[row, joint]:.6g} rad outside "
                f"[{m_lo:.6g}, {m_hi:.6g}]"
            )
        return row, f"joint {joint + 1}: {value:.6g} rad outside [{lo:.6g}, {hi:.6g}]"

    def configuration(self, name: str) -> tuple[float, ...]:
        """A named configuration (6 model angles, rad), or one line saying it is missing."""
        if name not in self.configurations:
            known = ", ".join(sorted(self.configurations))
            raise DescriptionError(f"robot {self.name} has no {name!r} configuration ({known})")
        return self.configurations[name]

    @property
    def upright_rad(self) -> tuple[float, float]:
        """Joints 2 and 3 of the ``upright`` configuration (rad)."""
        q = self.configuration("upright")
        return (q[1], q[2])

    @property
    def neutral_wrist_rad(self) -> tuple[float, float]:
        """Joints 4 and 5 of the ``upright`` configuration (rad)."""
        q = self.configuration("upright")
        return (q[3], q[4])

    @property
    def has_masses(self) -> bool:
        return self.mass_kg is not None

    # -- the controller's frames in the model's -----------------------------------------

    @property
    def model_base2controller_base(self) -> np.ndarray:
        """The controller's base/world frame in MDH frame 0 (4, 4), mm.

        ``inv(base_offset) @ base2controller_base``: a pose ``T`` the pendant
        shows in the controller's base frame is ``model_base2controller_base @
        T`` in the model's base frame (the frame of :func:`kinematics.chain`).
        """
        return frames.invert(self.base_offset) @ self.base2controller_base

    @property
    def model_flange2controller_flange(self) -> np.ndarray:
        """The controller's flange (tool 0) in the MDH flange frame (4, 4), mm.

        ``flange_offset @ flange2controller_flange``: a controller tool ``X``
        (given on its flange) is ``model_flange2controller_flange @ X`` on the
        model's flange, so the model's ``chain(q) @ model_flange2controller_flange``
        is the pose of tool 0 (the pendant's all-zero tool).
        """
        return self.flange_offset @ self.flange2controller_flange

    @property
    def has_controller_frames(self) -> bool:
        """Whether either controller frame differs from the description's own."""
        return not (
            np.array_equal(self.base2controller_base, np.eye(4))
            and np.array_equal(self.flange2controller_flange, np.eye(4))
        )

    def as_dict(self) -> dict[str, Any]:
        """The canonical content: plain lists and numbers (the YAML format's body)."""

        def arr(a: np.ndarray | None) -> Any:
            return None if a is None else np.asarray(a).tolist()

        body = self.body
        out = {
            "format": FORMAT,
            "name": self.name,
            "family": self.family,
            "source": self.source,
            "mdh": arr(self.mdh),
            "joint_limits_rad": arr(self.joint_limits_rad),
            "max_joint_speed_rad_s": arr(self.max_joint_speed_rad_s),
            "max_joint_accel_rad_s2": arr(self.max_joint_accel_rad_s2),
            "mass_kg": arr(self.mass_kg),
            "com_mm": arr(self.com_mm),
            "base_offset": arr(self.base_offset),
            "flange_offset": arr(self.flange_offset),
            "reference_errors": arr(self.reference_errors),
            "configurations": {k: list(v) for k, v in sorted(self.configurations.items())},
            "convention": {
                "sign": list(self.convention.sign),
                "offset_rad": list(self.convention.offset_rad),
                "couplings": [list(c) for c in self.convention.couplings],
                "source": self.convention.source,
            },
            "body": None
            if body is None
            else {
                "base_radius_mm": body.base_radius_mm,
                "base_top_mm": body.base_top_mm,
                "mount_z_mm": body.mount_z_mm,
                "shoulder_mm": list(body.shoulder_mm),
                "margin_mm": body.margin_mm,
                "source": body.source,
                "capsules": [
                    {
                        "name": c.name,
                        "link": c.link,
                        "p_mm": list(c.p_mm),
                        "q_mm": list(c.q_mm),
                        "radius_mm": c.radius_mm,
                    }
                    for c in body.capsules
                ],
            },
        }
        if self.limit_notes:
            # Only where there are some: every other description's digest stays as it was.
            out["limit_notes"] = list(self.limit_notes)
        if self.controller_limits_rad is not None:
            out["controller_limits_rad"] = arr(self.controller_limits_rad)
        if self.has_controller_frames:
            # Likewise: a description whose frames are the controller's (UR's DH
            # frames, an MDH table's) keeps its old digest, whatever sources it states.
            out["controller_frames"] = {
                "base2controller_base": arr(self.base2controller_base),
                "base_source": self.controller_base_source,
                "flange2controller_flange": arr(self.flange2controller_flange),
                "flange_source": self.controller_flange_source,
            }
        return out

    @property
    def digest(self) -> str:
        """``sha256:`` of the canonical content but the name (sorted-key JSON, floats by repr).

        Two descriptions with the same digest describe the same arm to the
        last bit; plan files and sessions record it to refuse a mismatch.
        """
        content = self.as_dict()
        del content["name"]  # a description file moved or renamed is the same arm
        text = json.dumps(content, sort_keys=True, separators=(",", ":"))
        return "sha256:" + hashlib.sha256(text.encode("utf-8")).hexdigest()
