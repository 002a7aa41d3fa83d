"""Named robot models: nominal MDH tables and joint limits.

Tables use the columns of :data:`calibrator.kinematics.COLUMNS`
(``a_mm, alpha_rad, theta_rad, d_mm, beta_rad``), the robot base frame at
joint 1 and the flange frame at the end of link 6.

Sources
-------
``er10l-c10``
    Seed 003, the ER10L-C10 nominal table (a, alpha, theta, d). Its joint
    range is the seed's simulation range, [-pi, pi] on every joint (the
    manufacturer's limits are not in the paper).
``ur5e``, ``ur10e``, ``ur10``
    Universal Robots' published DH parameters (``ur10``: the CB3 UR10;
    standard DH, which is MDH with beta = 0); joint limits and speeds from
    UR's ROS 2 description (UniversalRobots/Universal_Robots_ROS2_Description,
    tag 2.4.5, ``config/<model>/joint_limits.yaml``).

Motion ceilings
---------------
Every model carries a fixed ceiling on the speed (1.0 rad/s) and acceleration
(2.0 rad/s^2) of the moves a calibration run commands. They sit well below the
data sheets (UR's slowest joints turn at 2.09 rad/s; URScript's default
``movej`` acceleration is 1.4 rad/s^2 and ur-rtde accepts up to 40), because a
calibration run gains nothing from fast moves and a tracker cell is crowded.
Options such as ``--speed``, ``--accel`` and ``--max-speed`` can only lower them.
"""

from dataclasses import dataclass

import numpy as np

from calibrator.errors import CalibrationError

_DEG = np.pi / 180.0


@dataclass(frozen=True)
class RobotModel:
    """A named arm.

    Attributes
    ----------
    name : str
    mdh : ndarray, shape (6, 5)
        Nominal MDH table (mm, rad).
    joint_limits_rad : ndarray, shape (6, 2)
        ``[min, max]`` joint angle per joint (rad).
    max_joint_speed_rad_s : ndarray, shape (6,)
        Joint speed limits (rad/s).
    move_speed_cap_rad_s : float
        Ceiling on the leading-joint speed of any move ``calibrator`` commands,
        rad/s. Fixed per model: options may lower it, never raise it.
    move_accel_cap_rad_s2 : float
        Ceiling on the leading-joint acceleration of any move, rad/s^2. Fixed
        per model: options may lower it, never raise it.
    """

    name: str
    mdh: np.ndarray
    joint_limits_rad: np.ndarray
    max_joint_speed_rad_s: np.ndarray
    move_speed_cap_rad_s: float = 1.0
    move_accel_cap_rad_s2: float = 2.0

    def __post_init__(self):
        for field in ("mdh", "joint_limits_rad", "max_joint_speed_rad_s"):
            value = np.array(getattr(self, field), dtype=float)
            value.setflags(write=False)
            object.__setattr__(self, field, value)


def _mdh(a, alpha_deg, theta_deg, d):
    table = np.zeros((6, 5))
    table[:, 0] = a
    table[:, 1] = np.asarray(alpha_deg) * _DEG
    table[:, 2] = np.asarray(theta_deg) * _DEG
    table[:, 3] = d
    return table


def _ur(d1, a2, a3, d4, d5, d6, speeds_deg):
    return dict(
        mdh=_mdh([0, a2, a3, 0, 0, 0], [90, 0, 0, 90, -90, 0], [0] * 6, [d1, 0, 0, d4, d5, d6]),
        # Elbow limited to +-pi by construction; the other joints turn +-2 pi.
        joint_limits_rad=np.array([[-2, 2], [-2, 2], [-1, 1], [-2, 2], [-2, 2], [-2, 2]]) * np.pi,
        max_joint_speed_rad_s=np.asarray(speeds_deg) * _DEG,
    )


_UR10_SPEEDS_DEG = (120, 120, 180, 180, 180, 180)

# Each entry builds its tables when asked, so that nothing here is computed
# at import time (mutation testing cannot reach code run on import).
_MODELS = {
    "er10l-c10": lambda: dict(
        mdh=_mdh(
            [170, 780, 140, 0, 0, 0],
            [-90, 0, -90, 90, -90, 0],
            [0, -90, 0, 0, 0, 0],
            [0, 0, 0, 1060, 0, 125],
        ),
        joint_limits_rad=np.tile([-np.pi, np.pi], (6, 1)),
        max_joint_speed_rad_s=np.full(6, 180 * _DEG),
    ),
    "ur5e": lambda: _ur(162.5, -425.0, -392.2, 133.3, 99.7, 99.6, [180] * 6),
    "ur10": lambda: _ur(127.3, -612.0, -572.3, 163.941, 115.7, 92.2, _UR10_SPEEDS_DEG),
    "ur10e": lambda: _ur(180.7, -612.7, -571.55, 174.15, 119.85, 116.55, _UR10_SPEEDS_DEG),
}

#: Names accepted by :func:`get_model`.
MODEL_NAMES = tuple(sorted(_MODELS))


def get_model(name: str) -> RobotModel:
    """Return the :class:`RobotModel` called ``name`` (case-insensitive).

    Raises
    ------
    CalibrationError
        If no model has that name.
    """
    key = str(name).strip().lower()
    if key not in _MODELS:
        raise CalibrationError(f"unknown model {name!r}; known: {', '.join(MODEL_NAMES)}")
    return RobotModel(name=key, **_MODELS[key]())
