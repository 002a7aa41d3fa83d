"""Universal Robots arms: UR5e, UR10 (CB3) and UR10e.

Sources
-------
Kinematics
    Universal Robots' published DH parameters (standard DH, which is MDH with
    ``beta = 0``; ``ur10`` is the CB3 UR10).
Joint limits and speeds
    UR's ROS 2 description (UniversalRobots/Universal_Robots_ROS2_Description,
    tag 2.4.5, ``config/<model>/joint_limits.yaml``): +-360 deg on every joint
    but the elbow (+-180 deg).
Masses
    UR's published "DH parameters for calculations of kinematics and
    dynamics" tables (mass and centre of mass per link, in the DH frame of
    the link). No inertia tensors are published there.
Body
    The lateral offsets of the upper arm and forearm along the shoulder axis
    (UR's "shoulder offset" and "elbow offset": 176 and 137 mm on the UR10e,
    138 and 131 mm on the UR5e, 220.9 and 171.9 mm on the UR10) and the
    diameters of the base (190 mm UR10/UR10e, 149 mm UR5e), joint housings
    and tubes are those of UR's published dimension drawings, each radius
    rounded *up* to the next 5 mm so the capsules enclose the real links.
Joint convention
    The controller shows the DH angles themselves (PolyScope and URScript).
Controller frames
    UR's DH frame 0 is the controller's Base frame and the DH flange frame its
    tool flange: ur_description (ros-industrial/universal_robot,
    ``ur_description/urdf/inc/ur_macro.xacro``, commit 0290bd26) names them
    ``base`` (``base_link`` turned 180 deg about z, "to correctly align 'base'
    with the 'Base' coordinate system of the UR controller") and ``tool0``,
    "coincident with an all-zeros toolframe". Both are the description's own
    frames here (identity).
"""

from __future__ import annotations

import numpy as np

from calibrator.robots.description import Body, Capsule, JointConvention, RobotDescription

#: Family of arms whose controller keeps a calibration as UR DH deltas.
FAMILY = "ur"
_DEG = np.pi / 180.0

# UR publishes the same centres of mass for the UR10 and the UR10e (m, DH frame of the link).
_UR10_COM_M = [
    [0.021, 0.0, 0.027],
    [0.38, 0.0, 0.158],
    [0.24, 0.0, 0.068],
    [0.0, 0.007, 0.018],
    [0.0, 0.007, 0.018],
    [0.0, 0.0, -0.026],
]
_UR5E_COM_M = [
    [0.0, -0.02561, 0.00193],
    [0.2125, 0.0, 0.11336],
    [0.15, 0.0, 0.0265],
    [0.0, -0.0018, 0.01634],
    [0.0, 0.0018, 0.01634],
    [0.0, 0.0, -0.001159],
]
_UR10_SPEEDS_DEG = (120, 120, 180, 180, 180, 180)
_UR_DESCRIPTION = "ros-industrial/universal_robot ur_description/urdf/inc/ur_macro.xacro (0290bd26)"
_UR_BASE = (
    f"UR's Base frame is DH frame 0: link 'base' of {_UR_DESCRIPTION} "
    "(base_link turned 180 deg about z)"
)
_UR_FLANGE = f"UR's tool flange is the DH flange frame: link 'tool0' of {_UR_DESCRIPTION}"


def _capsules(mdh: np.ndarray, body: tuple[float, ...]) -> tuple[Capsule, ...]:
    """Capsules of a UR arm in its link frames (mm), from its table and drawing sizes."""
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


def _ur(
    name: str,
    dh_mm: tuple[float, ...],
    speeds_deg: tuple[float, ...],
    mass_kg: list[float],
    com_m: list[list[float]],
    body: tuple[float, ...],
) -> RobotDescription:
    """A UR arm from its published numbers.

    ``dh_mm`` is ``(d1, a2, a3, d4, d5, d6)``; ``body`` is (shoulder offset,
    elbow offset, base radius, shoulder/elbow housing radius, upper arm tube,
    forearm tube, wrist housing radius), mm, from UR's drawings.
    """
    d1, a2, a3, d4, d5, d6 = dh_mm
    mdh = np.zeros((6, 5))
    mdh[:, 0] = [0, a2, a3, 0, 0, 0]
    mdh[:, 1] = np.array([90, 0, 0, 90, -90, 0]) * _DEG
    mdh[:, 3] = [d1, 0, 0, d4, d5, d6]
    return RobotDescription(
        name=name,
        family=FAMILY,
        mdh=mdh,
        # Elbow limited to +-pi by construction; the other joints turn +-2 pi.
        joint_limits_rad=np.array([[-2, 2], [-2, 2], [-1, 1], [-2, 2], [-2, 2], [-2, 2]]) * np.pi,
        max_joint_speed_rad_s=np.asarray(speeds_deg) * _DEG,
        body=Body(
            capsules=_capsules(mdh, body),
            base_radius_mm=body[2],
            base_top_mm=d1,
            mount_z_mm=0.0,
            shoulder_mm=(0.0, 0.0, d1),
            source="UR's published dimension drawings, radii rounded up to 5 mm",
        ),
        configurations={
            "home": (0.0,) * 6,
            # Upper arm and forearm straight up; wrist 1 turns the flange up.
            "upright": (0.0, -np.pi / 2, 0.0, -np.pi / 2, 0.0, 0.0),
        },
        mass_kg=np.array(mass_kg),
        com_mm=np.array(com_m) * 1000.0,
        convention=JointConvention(source="PolyScope/URScript show the DH angles"),
        controller_base_source=_UR_BASE,
        controller_flange_source=_UR_FLANGE,
        source="Universal Robots' published DH and mass tables; UR ROS 2 description 2.4.5",
    )


#: The arms of this family, built when asked.
DESCRIPTIONS = {
    "ur5e": lambda: _ur(
        "ur5e",
        (162.5, -425.0, -392.2, 133.3, 99.7, 99.6),
        (180,) * 6,
        [3.761, 8.058, 2.846, 1.37, 1.3, 0.365],
        _UR5E_COM_M,
        (138.0, 131.0, 75.0, 60.0, 45.0, 40.0, 45.0),
    ),
    "ur10": lambda: _ur(
        "ur10",
        (127.3, -612.0, -572.3, 163.941, 115.7, 92.2),
        _UR10_SPEEDS_DEG,
        [7.1, 12.7, 4.27, 2.0, 2.0, 0.365],
        _UR10_COM_M,
        (220.941, 171.9, 95.0, 75.0, 60.0, 50.0, 50.0),
    ),
    "ur10e": lambda: _ur(
        "ur10e",
        (180.7, -612.7, -571.55, 174.15, 119.85, 116.55),
        _UR10_SPEEDS_DEG,
        [7.369, 13.051, 3.989, 2.1, 1.98, 0.615],
        _UR10_COM_M,
        (176.0, 137.0, 95.0, 75.0, 60.0, 50.0, 50.0),
    ),
}
