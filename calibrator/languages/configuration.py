"""An arm's configuration read off its joint values, for any 6R arm.

A Cartesian target names a tool pose, which a 6R arm reaches with up to
eight joint solutions (and more when a joint turns beyond one revolution).
Controllers store with each target which one was meant. They all describe
the same three choices, which are read here from the model's geometry, for a
generic 6R arm with a spherical (or nearly spherical) wrist:

shoulder (``front`` 0 / ``back`` 1)
    The wrist centre (the origin of link frame 4, on axis 5: the
    intersection of axes 4, 5 and 6 on a spherical wrist) expressed in the
    frame that turns with axis 1 (the base frame turned by joint 1): front
    when its x coordinate is >= 0 (KUKA's "basic area"), back when negative
    ("overhead area").
elbow (``up`` 0 / ``down`` 1)
    Which side of the lower arm (the line from axis 2 to axis 3) the wrist
    centre ``w`` lies on, seen along axis 2: with ``a2``, ``a3`` the origins of
    link frames 1 and 2 (on axes 2 and 3) and ``z`` the direction of axis 2,
    ``z . ((a3 - a2) x (w - a3)) >= 0`` is up. On the ER10L-C10 and UR arms
    that is the usual working pose (forearm above the line of the lower arm).
wrist (``noflip`` 0 / ``flip`` 1)
    The sign of joint 5 (model convention): flip when ``q5 < 0``.

The turn information (KUKA's T, RAPID's cf1/cf4/cf6, Fanuc's turn numbers,
Yaskawa's R/T/S >= 180 deg bits) is read by each language from the
controller's joint values (:mod:`calibrator.languages.convention`); the
helpers here compute the common pieces. Every function is vectorised over
poses.

A near-singular pose (the wrist's axes 4 and 6 aligned, the arm stretched,
the wrist centre on axis 1) is where a small pose change turns the joints a
lot; :func:`calibrator.model.singularities.nearest` names the closest one, to
explain a compensation that failed or jumped.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from calibrator.model import kinematics

#: Names of the three geometric bits, in column order of :func:`arm_bits`.
BITS = ("shoulder", "elbow", "wrist")
#: What 0 and 1 mean for each bit.
BIT_NAMES = (("front", "back"), ("up", "down"), ("noflip", "flip"))


def _points(mdh: ArrayLike, q_model: np.ndarray) -> tuple[np.ndarray, ...]:
    """``o1, o2, w, x1, z1`` of :func:`calibrator.model.singularities.points`, each (N, 3).

    The same numbers, read off the links' top rows: the bits are taken of
    every solution a filter tries, and making every link frame 4x4 first
    costs a third of the time.
    """
    mdh = kinematics.check_mdh(mdh)
    _, tops = kinematics.chain_parts(
        kinematics.link_constants(mdh),
        kinematics.joint_phases(mdh[..., kinematics.THETA]),
        kinematics.joint_phases(q_model),
        all_frames=True,
    )
    return tops[:, 1, :, 3], tops[:, 2, :, 3], tops[:, 4, :, 3], tops[:, 1, :, 0], tops[:, 1, :, 2]


def arm_bits(mdh: ArrayLike, q_model: ArrayLike) -> np.ndarray:
    """Shoulder, elbow and wrist bits of joint solutions.

    Parameters
    ----------
    mdh : array_like, shape (6, 5)
        The arm's table (nominal, for a controller's view).
    q_model : array_like, shape (N, 6)
        Joint angles in the model's convention (rad).

    Returns
    -------
    ndarray of int, shape (N, 3)
        Columns :data:`BITS`, values as in :data:`BIT_NAMES`.
    """
    q_model = kinematics.check_joints(q_model)
    o1, o2, w, x1, z1 = _points(mdh, q_model)
    # x of the wrist centre in the frame turned by axis 1 (axis 1 is the base z axis).
    a1 = np.arctan2(x1[:, 1], x1[:, 0])
    front_x = w[:, 0] * np.cos(a1) + w[:, 1] * np.sin(a1)
    side = np.einsum("ij,ij->i", z1, np.cross(o2 - o1, w - o2))
    return np.column_stack([front_x < 0, side < 0, q_model[:, 4] < 0]).astype(int)


def describe_bits(bits: ArrayLike) -> str:
    """``front, up, noflip`` for one row of :func:`arm_bits`."""
    return ", ".join(BIT_NAMES[i][int(b)] for i, b in enumerate(np.asarray(bits)[:3]))


def quadrant(q_deg: ArrayLike) -> np.ndarray:
    """ABB's quadrant number of joint angles (deg): ``floor(q / 90)``, so 0 is [0, 90)."""
    return np.floor(np.asarray(q_deg, dtype=float) / 90.0).astype(int)


def turn(q_deg: ArrayLike) -> np.ndarray:
    """Fanuc's turn number (deg): 0 on (-180, 180], 1 on (180, 540], -1 on (-540, -180]."""
    return np.ceil((np.asarray(q_deg, dtype=float) - 180.0) / 360.0).astype(int)


def negative(q_deg: ArrayLike) -> np.ndarray:
    """1 where a joint angle is negative (KUKA's turn bits), else 0."""
    return (np.asarray(q_deg, dtype=float) < 0).astype(int)


def beyond_half_turn(q_deg: ArrayLike) -> np.ndarray:
    """1 where a joint angle lies outside [-180, 180) deg (Yaskawa's ``>= 180`` bits)."""
    q = np.asarray(q_deg, dtype=float)
    return ((q >= 180.0) | (q < -180.0)).astype(int)
