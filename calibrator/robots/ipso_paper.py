"""The IPSO paper's arm (reference paper 003): an ER10L-C10, 10 kg, 1.4 m.

Sources
-------
Kinematics
    The paper's Table 1, the ER10L-C10 nominal table (a, alpha, theta, d).
Joint range
    The paper's simulation range, [-pi, pi] on every joint (the
    manufacturer's limits are not in the paper); 180 deg/s on every joint.
Reference errors
    The paper's Table 2: the errors it injects into the arm (a, alpha, theta,
    d, beta), used by ``calibrator simulate --errors ref003``.
Body
    The paper gives no link dimensions. The capsules follow the MDH segments
    with radii of a generic 10 kg, 1.4 m arm (turret 130 mm, upper arm and
    elbow 110 mm, forearm 90 mm, wrist 70 mm), and the base stands 450 mm
    below the shoulder (the base frame of the table sits at the shoulder
    height, ``d1 = 0``). A stated approximation: use a cell file's
    ``mounting_plane_z_mm`` for the real robot.
Masses
    Not published.
"""

from __future__ import annotations

import numpy as np

from calibrator.robots.description import Body, Capsule, RobotDescription

#: The arm's name.
NAME = "er10l-c10"
_DEG = np.pi / 180.0

#: The paper's Table 2: errors injected into the arm (a, alpha, theta, d, beta).
TABLE_2_ERRORS = (
    (-0.4751, 0.0058, 0.0091, -0.4221, 0.0),
    (0.2565, 0.0092, -0.0003, 0.0, -0.0028),
    (-0.3366, 0.0031, 0.0060, 0.3409, 0.0),
    (-0.1827, -0.0093, -0.0072, 0.1420, 0.0),
    (-0.1117, 0.0070, -0.0016, 0.1753, 0.0),
    (-0.2536, 0.0087, 0.0083, 0.1531, 0.0),
)


def _capsules(mdh: np.ndarray) -> tuple[Capsule, ...]:
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


def _describe() -> RobotDescription:
    mdh = np.zeros((6, 5))
    mdh[:, 0] = [170, 780, 140, 0, 0, 0]
    mdh[:, 1] = np.array([-90, 0, -90, 90, -90, 0]) * _DEG
    mdh[:, 2] = np.array([0, -90, 0, 0, 0, 0]) * _DEG
    mdh[:, 3] = [0, 0, 0, 1060, 0, 125]
    return RobotDescription(
        name=NAME,
        mdh=mdh,
        joint_limits_rad=np.tile([-np.pi, np.pi], (6, 1)),
        max_joint_speed_rad_s=np.full(6, 180 * _DEG),
        body=Body(
            capsules=_capsules(mdh),
            base_radius_mm=150.0,
            base_top_mm=-130.0,
            mount_z_mm=-450.0,
            shoulder_mm=(0.0, 0.0, 0.0),
            source="generic 10 kg, 1.4 m arm (the paper gives no link dimensions)",
        ),
        configurations={
            "home": (0.0,) * 6,
            # The arm straight up, as the cell's via poses take it (joints 2 and 3).
            "upright": (0.0, 0.0, -np.pi / 2, 0.0, 0.0, 0.0),
        },
        reference_errors=np.array(TABLE_2_ERRORS),
        source="reference paper 003 (IPSO), Tables 1 and 2",
    )


#: The arms of this module, built when asked.
DESCRIPTIONS = {NAME: _describe}
