"""The arm as capsules, for collision and line-of-sight checks.

Each link is one or more capsules (a segment and a radius) fixed in the frame
of that link, placed at each pose from the nominal MDH frames
(:func:`calibrator.model.kinematics.chain`); the base is a vertical cylinder on the
mounting plane; the tool (reflector holder) is a capsule from the flange
origin to the tool point.

Sources and approximations
--------------------------
The capsules, base and named configurations are the arm's description's
(:attr:`calibrator.robots.RobotDescription.body`); each description module
names where its radii come from and what they approximate.

Frames: positions in the robot base frame, mm.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from calibrator import robots
from calibrator.errors import CalibrationError
from calibrator.model import kinematics
from calibrator.robots import Capsule, RobotDescription

__all__ = ["ArmGeometry", "Capsule", "arm_geometry", "place"]


@dataclass(frozen=True)
class ArmGeometry:
    """The capsules of an arm, its base cylinder and its nominal table.

    Attributes
    ----------
    model : str
    mdh : ndarray, shape (6, 5)
        Nominal MDH table (mm, rad) that places the capsules.
    capsules : tuple of Capsule
        The tool capsule last (link 7).
    base_radius_mm : float
        Base cylinder about the base z axis, from the mounting plane up to
        ``base_top_mm``.
    base_top_mm : float
        Top of the base cylinder (joint 1's housing included), base frame z, mm.
    mount_z_mm : float
        Where the base stands: the mounting plane's z in the base frame, mm.
    reach_mm : float
        Largest distance of the tool point from the shoulder, mm (reach envelope).
    shoulder_mm : tuple of 3 float
        Centre of the reach envelope in the base frame (on the base axis), mm.
    upright_rad : tuple of float
        Values of joints 2 and 3 that hold the arm straight up (via poses).
    neutral_wrist_rad : tuple of float
        Values of joints 4 and 5 that, upright, point the flange straight up:
        turning joints 1 and 6 there sweeps nothing into the arm.
    """

    model: str
    mdh: np.ndarray
    capsules: tuple[Capsule, ...]
    base_radius_mm: float
    base_top_mm: float
    mount_z_mm: float
    reach_mm: float
    shoulder_mm: tuple[float, float, float]
    upright_rad: tuple[float, float]
    neutral_wrist_rad: tuple[float, float]

    @property
    def links(self) -> np.ndarray:
        """Link index of each capsule, shape (K,)."""
        return np.array([c.link for c in self.capsules])

    @property
    def radii(self) -> np.ndarray:
        """Radius of each capsule, shape (K,), mm."""
        return np.array([c.radius_mm for c in self.capsules])

    @property
    def names(self) -> tuple[str, ...]:
        """Name of each capsule."""
        return tuple(c.name for c in self.capsules)


def arm_geometry(
    model: str | RobotDescription,
    mdh: np.ndarray,
    tool_mm: ArrayLike,
    tool_radius_mm: float = 20.0,
) -> ArmGeometry:
    """The capsule model of an arm with a tool.

    Parameters
    ----------
    model : str or RobotDescription
        The arm's description, or its name (:func:`calibrator.robots.get`).
    mdh : array_like, shape (6, 5)
        The model's nominal MDH table (mm, rad).
    tool_mm : array_like, shape (3,)
        Tool point (reflector centre) in the flange frame, mm.
    tool_radius_mm : float
        Radius of the tool capsule (a 1.5" reflector is 19 mm), mm.

    Returns
    -------
    ArmGeometry

    Raises
    ------
    CalibrationError
        An arm whose description has no body, or a non-finite tool.
    """
    mdh = kinematics.check_mdh(mdh)
    tool = np.asarray(tool_mm, dtype=float).reshape(3)
    if not np.all(np.isfinite(tool)) or np.abs(tool).max() > 5000.0:
        raise CalibrationError(f"tool point {tool.tolist()} mm: not a tool (finite, within 5 m)")
    description = model if isinstance(model, RobotDescription) else _described(model)
    body = description.body
    if body is None:
        raise CalibrationError(f"no geometric model for {description.name!r}")
    # The tool capsule starts a radius out of the flange: the flange itself is wrist 3.
    start = tool * min(1.0, tool_radius_mm / max(float(np.linalg.norm(tool)), 1e-9))
    tool_cap = Capsule("tool", 7, tuple(start), tuple(tool), tool_radius_mm)
    reach = float(np.abs(mdh[:, 0]).sum() + np.abs(mdh[1:, 3]).sum() + np.linalg.norm(tool))
    return ArmGeometry(
        model=description.name,
        mdh=mdh,
        capsules=body.capsules + (tool_cap,),
        base_radius_mm=body.base_radius_mm,
        base_top_mm=float(body.base_top_mm),
        mount_z_mm=body.mount_z_mm,
        reach_mm=reach,
        shoulder_mm=body.shoulder_mm,
        upright_rad=description.upright_rad,
        neutral_wrist_rad=description.neutral_wrist_rad,
    )


def _described(name: str) -> RobotDescription:
    try:
        return robots.get(name)
    except robots.DescriptionError:
        raise CalibrationError(f"no geometric model for {name!r}") from None


def place(geometry: ArmGeometry, q: ArrayLike) -> np.ndarray:
    """Capsule end points at each pose, base frame.

    Parameters
    ----------
    geometry : ArmGeometry
    q : array_like, shape (N, 6)
        Joint angles, rad.

    Returns
    -------
    ndarray, shape (N, K, 2, 3)
        End points of the K capsules, mm, base frame.
    """
    q = kinematics.check_joints(q)
    _, frames = kinematics.chain(geometry.mdh, q, all_frames=True)  # (N, 7, 4, 4)
    links = np.minimum(geometry.links, 6)  # the tool rides on the flange (frame 6)
    ends = np.array([[c.p_mm, c.q_mm] for c in geometry.capsules])  # (K, 2, 3)
    placed = frames[:, links]  # (N, K, 4, 4)
    rot, org = placed[..., :3, :3], placed[..., :3, 3]
    return np.einsum("nkij,kej->nkei", rot, ends) + org[:, :, np.newaxis, :]
