"""The arm as capsules, for collision and line-of-sight checks.

Each link is one or more capsules (a segment and a radius) fixed in the frame
of that link, placed at each pose from the nominal MDH frames
(:func:`calibrator.kinematics.chain`); the base is a vertical cylinder on the
mounting plane; the tool (reflector holder) is a capsule from the flange
origin to the tool point.

Sources and approximations
--------------------------
``ur5e``, ``ur10e``, ``ur10``
    The DH offsets are UR's published ones (see :mod:`calibrator.models`).
    The lateral offsets of the upper arm and forearm along the shoulder axis
    (UR's "shoulder offset" and "elbow offset": 176 and 137 mm on the UR10e,
    138 and 131 mm on the UR5e, 220.9 and 171.9 mm on the UR10) and the
    diameters of the base (190 mm UR10/UR10e, 149 mm UR5e), joint housings
    and tubes are those of UR's published dimension drawings, each radius
    rounded *up* to the next 5 mm so the capsules enclose the real links.
``er10l-c10``
    The seed gives no link dimensions. The capsules follow the MDH segments
    with radii of a generic 10 kg, 1.4 m arm (turret 130 mm, upper arm and
    elbow 110 mm, forearm 90 mm, wrist 70 mm), and the base stands 450 mm
    below the shoulder (the base frame of the seed's table sits at the
    shoulder height, ``d1 = 0``). A stated approximation: use a cell file's
    ``mounting_plane_z_mm`` for the real robot.

Frames: positions in the robot base frame, mm.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from calibrator import kinematics
from calibrator.errors import CalibrationError


@dataclass(frozen=True)
class Capsule:
    """A segment ``p``-``q`` with a radius, fixed in the frame of one link.

    Attributes
    ----------
    name : str
        What it is ("upper arm", "wrist 2", ...), used in messages.
    link : int
        Link it belongs to: 0 base, 1..6 the links (frame i of
        :func:`calibrator.kinematics.chain`), 7 the tool (on the flange).
    p_mm, q_mm : tuple of 3 float
        End points in the link's frame, mm.
    radius_mm : float
    """

    name: str
    link: int
    p_mm: tuple[float, float, float]
    q_mm: tuple[float, float, float]
    radius_mm: float


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


# UR: (shoulder offset, elbow offset, base radius, shoulder/elbow housing radius,
# upper arm tube, forearm tube, wrist housing radius), mm, from UR's drawings.
_UR_BODY = {
    "ur5e": (138.0, 131.0, 75.0, 60.0, 45.0, 40.0, 45.0),
    "ur10e": (176.0, 137.0, 95.0, 75.0, 60.0, 50.0, 50.0),
    "ur10": (220.941, 171.9, 95.0, 75.0, 60.0, 50.0, 50.0),
}


def _ur_capsules(mdh: np.ndarray, body: tuple[float, ...]) -> tuple[Capsule, ...]:
    a2, a3 = mdh[1, 0], mdh[2, 0]
    d4, d5, d6 = mdh[3, 3], mdh[4, 3], mdh[5, 3]
    shoulder, elbow, _, joint_r, upper_r, fore_r, wrist_r = body
    fore = shoulder - elbow  # forearm tube's offset along the parallel axes
    return (
        # Shoulder housing: on the shoulder axis (z of frame 1), from behind the
        # base axis to the upper arm.
        Capsule("shoulder", 1, (0.0, 0.0, -joint_r), (0.0, 0.0, shoulder), joint_r),
        # Frame 2 sits on the elbow axis; the shoulder is at -a2 along its x.
        Capsule("upper arm", 2, (-a2, 0.0, shoulder), (0.0, 0.0, shoulder), upper_r),
        Capsule("elbow", 2, (0.0, 0.0, fore), (0.0, 0.0, shoulder), joint_r),
        Capsule("forearm", 3, (-a3, 0.0, fore), (0.0, 0.0, fore), fore_r),
        Capsule("wrist 1", 3, (0.0, 0.0, fore), (0.0, 0.0, d4 + wrist_r), wrist_r),
        # Frame 4 on the wrist-1 axis; wrist 2 sits d5 along its z.
        Capsule("wrist 2", 4, (0.0, 0.0, 0.0), (0.0, 0.0, d5 + wrist_r), wrist_r),
        Capsule("wrist 3", 5, (0.0, 0.0, -wrist_r), (0.0, 0.0, d6), wrist_r),
    )


def _er10l_capsules(mdh: np.ndarray) -> tuple[Capsule, ...]:
    a1, a2, a3, d4, d6 = mdh[0, 0], mdh[1, 0], mdh[2, 0], mdh[3, 3], mdh[5, 3]
    return (
        Capsule("turret", 1, (-a1, 0.0, 0.0), (0.0, 0.0, 0.0), 130.0),
        Capsule("upper arm", 2, (-a2, 0.0, 0.0), (0.0, 0.0, 0.0), 110.0),
        Capsule("elbow", 3, (-a3, 0.0, 0.0), (0.0, 0.0, 0.0), 110.0),
        # The forearm rolls about its own axis (joint 4): a capsule on that axis.
        # In two parts: the far one is what folding the elbow brings to the upper arm.
        Capsule("forearm", 3, (0.0, 0.0, 0.0), (0.0, 0.0, 300.0), 90.0),
        Capsule("forearm end", 3, (0.0, 0.0, 300.0), (0.0, 0.0, d4 - 90.0), 90.0),
        Capsule("wrist", 5, (0.0, 0.0, -70.0), (0.0, 0.0, d6), 70.0),
    )


def arm_geometry(
    model: str, mdh: np.ndarray, tool_mm: ArrayLike, tool_radius_mm: float = 20.0
) -> ArmGeometry:
    """The capsule model of a named arm with a tool.

    Parameters
    ----------
    model : str
        A name of :data:`calibrator.models.MODEL_NAMES`.
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
        A model without a geometric model, or a non-finite tool.
    """
    mdh = kinematics.check_mdh(mdh)
    tool = np.asarray(tool_mm, dtype=float).reshape(3)
    if not np.all(np.isfinite(tool)) or np.abs(tool).max() > 5000.0:
        raise CalibrationError(f"tool point {tool.tolist()} mm: not a tool (finite, within 5 m)")
    if model in _UR_BODY:
        body = _UR_BODY[model]
        caps = _ur_capsules(mdh, body)
        base_r, base_top, mount = body[2], mdh[0, 3], 0.0
        shoulder = (0.0, 0.0, float(mdh[0, 3]))
        upright = (-np.pi / 2, 0.0)
        neutral = (-np.pi / 2, 0.0)
    elif model == "er10l-c10":
        caps = _er10l_capsules(mdh)
        base_r, base_top, mount = 150.0, -130.0, -450.0
        shoulder = (0.0, 0.0, 0.0)
        upright = (0.0, -np.pi / 2)
        neutral = (0.0, 0.0)
    else:
        raise CalibrationError(f"no geometric model for {model!r}")
    # The tool capsule starts a radius out of the flange: the flange itself is wrist 3.
    start = tool * min(1.0, tool_radius_mm / max(float(np.linalg.norm(tool)), 1e-9))
    tool_cap = Capsule("tool", 7, tuple(start), tuple(tool), tool_radius_mm)
    reach = float(np.abs(mdh[:, 0]).sum() + np.abs(mdh[1:, 3]).sum() + np.linalg.norm(tool))
    return ArmGeometry(
        model=model,
        mdh=mdh,
        capsules=caps + (tool_cap,),
        base_radius_mm=base_r,
        base_top_mm=float(base_top),
        mount_z_mm=mount,
        reach_mm=reach,
        shoulder_mm=shoulder,
        upright_rad=upright,
        neutral_wrist_rad=neutral,
    )


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
