"""Exact conversions between MDH tables and other descriptions of the same arm.

Every description of a 6R arm (an MDH table, a standard DH table with UR's
huge ``d`` values, a ROS kinematics file, a URDF) fixes the same geometry:
the six joint axes and the flange frame at the zero pose. This module goes
through that geometry:

- :func:`joint_frames` turns an MDH (or standard DH) table into the frame
  each joint turns about, at ``q = 0``, in the base frame (z = the joint
  axis, origin on it) and the flange frame;
- :func:`fit_links` turns joint frames back into a table, joint by joint:
  given frame ``i-1`` (z along axis i), the next axis fixes the link:

  * standard DH (``hayati`` false): the common normal of axes i and i+1
    gives ``d_i`` (along axis i) and ``a_i``; ``alpha_i`` turns z onto
    axis i+1, ``beta_i = 0``. Nearly parallel axes give huge ``d_i``: this
    is the form of UR's factory calibration.
  * Hayati (``hayati`` true, where axes i and i+1 are nominally parallel):
    ``d_i`` keeps its reference value, the origin of frame i is where axis
    i+1 crosses the plane ``z = d_i`` of frame i-1, ``a_i`` is the distance
    to it, and ``Rx(alpha_i) Ry(beta_i)`` turns z onto axis i+1:
    with ``u`` the direction of axis i+1 after ``Rz(theta_i)``,
    ``beta_i = asin(u_x)``, ``alpha_i = atan2(-u_y, u_z)``.

  Both place frame i on axis i+1 with z along it, so the joint rotations are
  reproduced exactly; ``theta_{i+1}`` absorbs where frame i's x axis points.
  Of the two equivalent choices of each x axis (``theta`` or ``theta + pi``
  with ``a`` and ``alpha`` negated) the one nearer the reference table is
  kept. Link 6 has no next axis: ``A_6 = Rz(theta) Tz(d) Tx(a) Rx(alpha)
  Ry(beta)`` is read off the flange frame directly, and what that form
  cannot hold (a flange origin off the x-z plane, or ``beta_6`` where it is
  not allowed) is returned as a residual transform.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from calibrator.model import frames, kinematics, rotations
from calibrator.model.kinematics import ALPHA, BETA, THETA

#: Axes closer than this (rad) are treated as exactly parallel in standard DH:
#: the common normal is then taken at the reference ``d``.
_PARALLEL_EPS = 1e-12


def link(row: np.ndarray) -> np.ndarray:
    """``A_i`` at ``q_i = 0`` for one MDH row ``[a, alpha, theta, d, beta]``, (4, 4)."""
    # The kinematics' own chain, of a table whose other links are the identity.
    table = np.zeros((6, 5))
    table[0] = row
    return kinematics.chain(table, np.zeros((1, 6)))[0]


def joint_frames(mdh: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Joint frames at the zero pose and the flange frame of an MDH table.

    Parameters
    ----------
    mdh : array_like, shape (6, 5)
        MDH (or standard DH, ``beta = 0``) table, mm and rad.

    Returns
    -------
    joints : ndarray, shape (6, 4, 4)
        ``joints[i]`` is ``A_1 ... A_i`` at q = 0 (base frame): joint i+1 turns
        about its z axis.
    flange : ndarray, shape (4, 4)
    """
    _, frames = kinematics.chain(mdh, np.zeros((1, 6)), all_frames=True)
    return frames[0, :6], frames[0, 6]


def fit_links(
    joints: ArrayLike,
    flange: ArrayLike,
    reference: ArrayLike,
    hayati: Sequence[bool] | np.ndarray,
    beta6: bool = False,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A table reproducing given joint frames, near a reference table.

    Parameters
    ----------
    joints : array_like, shape (6, 4, 4)
        Frame of each joint at the zero pose, base frame: z along the axis,
        origin on it (mm). Only the axes matter.
    flange : array_like, shape (4, 4)
        Flange frame at the zero pose, base frame (mm).
    reference : array_like, shape (6, 5)
        Table whose branch choices (signs of ``a``, ``theta`` and ``alpha``
        within +-pi) and Hayati ``d`` values are kept.
    hayati : array_like of bool, shape (5,)
        Whether link i (1..5) uses Hayati's ``beta`` instead of the common normal.
    beta6 : bool
        Whether ``beta_6`` may be non-zero (else it goes to the residual).

    Returns
    -------
    mdh : ndarray, shape (6, 5)
    base2frame0 : ndarray, shape (4, 4)
        Frame 0 of the table in the source's base frame (identity when axis
        1 is the base z axis).
    residual : ndarray, shape (4, 4)
        ``flange = base2frame0 @ A_1...A_6(0) @ residual``; identity when the
        table holds the flange exactly.
    """
    joints = np.asarray(joints, dtype=float)
    reference = kinematics.check_mdh(reference)
    frame = _frame0(joints[0])
    base2frame0 = frame
    mdh = np.zeros((6, 5))
    for i in range(5):
        mdh[i] = _link_to_axis(frame, joints[i + 1], reference[i], bool(hayati[i]))
        frame = frame @ link(mdh[i])
    mdh[5], last = _last_link(frame, flange, reference[5], beta6)
    residual = np.linalg.inv(frame @ last) @ flange
    return mdh, base2frame0, residual


def _frame0(joint1):
    """Frame with z along axis 1, origin at its point nearest the base origin."""
    z = joint1[:3, 2] / np.linalg.norm(joint1[:3, 2])
    p = joint1[:3, 3]
    origin = p - z * (p @ z)
    x = np.array([1.0, 0.0, 0.0]) - z * z[0]
    if np.linalg.norm(x) < 1e-9:
        x = np.array([0.0, 1.0, 0.0]) - z * z[1]
    x /= np.linalg.norm(x)
    out = np.eye(4)
    out[:3, :3] = np.column_stack([x, np.cross(z, x), z])
    out[:3, 3] = origin
    return out


def _wrap_near(angle, ref):
    """``angle`` shifted by a multiple of 2 pi to lie within pi of ``ref``."""
    return ref + (angle - ref + np.pi) % (2 * np.pi) - np.pi


def _link_to_axis(frame, next_joint, ref, hayati):
    """MDH row placing the next frame on the next joint's axis (see module notes)."""
    r, o = frame[:3, :3], frame[:3, 3]
    p = r.T @ (next_joint[:3, 3] - o)
    u = r.T @ next_joint[:3, 2]
    u /= np.linalg.norm(u)
    sin_angle = np.hypot(u[0], u[1])
    if hayati or sin_angle < _PARALLEL_EPS:
        d = ref[kinematics.D]
        point = p + u * (d - p[2]) / u[2]
    else:
        # Closest points of the z axis (t e_z) and the next axis (p + s u).
        b = u[2]
        den = sin_angle**2  # 1 - b^2 without its cancellation for near-parallel axes
        w0_z, w0_u = -p[2], -(u @ p)
        d = (b * w0_u - w0_z) / den
        point = p + u * ((w0_u - b * w0_z) / den)
    v = point[:2]
    a = np.hypot(*v)
    if a > 1e-9:
        theta = np.arctan2(v[1], v[0])
    else:
        # Axes meet: x along z x u (either sign), or keep the reference if coincident.
        n = np.cross([0.0, 0.0, 1.0], u)
        theta = np.arctan2(n[1], n[0]) if np.linalg.norm(n) > 1e-12 else ref[THETA]
        a = 0.0
    best = None
    for flip in (0.0, np.pi):
        th = _wrap_near(theta + flip, ref[THETA])
        c, s = np.cos(th), np.sin(th)
        ux, uy = c * u[0] + s * u[1], -s * u[0] + c * u[1]
        beta = np.arcsin(np.clip(ux, -1.0, 1.0)) if hayati else 0.0
        alpha = _wrap_near(np.arctan2(-uy, u[2]), ref[ALPHA])
        row = np.array([a if flip == 0.0 else -a, alpha, th, d, beta])
        cost = abs(th - ref[THETA]) + abs(alpha - ref[ALPHA]) + abs(beta - ref[BETA])
        if best is None or cost < best[0]:
            best = (cost, row)
    return best[1]


def _last_link(frame, flange, ref, beta6):
    """Row of link 6 read off the flange frame, and its transform at q = 0."""
    m = np.linalg.inv(frame) @ np.asarray(flange, dtype=float)
    rot, t = m[:3, :3], m[:3, 3]
    best = None
    alpha0 = np.arcsin(np.clip(rot[2, 1], -1.0, 1.0))
    beta0 = np.arctan2(-rot[2, 0], rot[2, 2]) if beta6 else 0.0
    for alpha, beta, shift in ((alpha0, beta0, 0.0), (np.pi - alpha0, beta0 + np.pi, np.pi)):
        if not beta6 and shift:
            beta = 0.0
        rest = rot @ rotations.rotations_xyz([alpha, beta, 0.0]).T
        theta = _wrap_near(np.arctan2(rest[1, 0], rest[0, 0]), ref[THETA])
        alpha = _wrap_near(alpha, ref[ALPHA])
        beta = _wrap_near(beta, ref[BETA])
        a = t[0] * np.cos(theta) + t[1] * np.sin(theta)
        row = np.array([a, alpha, theta, t[2], beta])
        cost = abs(theta - ref[THETA]) + abs(alpha - ref[ALPHA]) + abs(beta - ref[BETA])
        if best is None or cost < best[0]:
            best = (cost, row)
    row = best[1]
    return row, link(row)


def residual_size(transform: ArrayLike) -> tuple[float, float]:
    """Translation (mm) and rotation angle (rad) of a residual transform."""
    t = np.asarray(transform, dtype=float)
    # through the rotation vector: arccos of the trace reads angles below ~2e-8 rad as 0
    angle = np.linalg.norm(rotations.matrix_to_rotvec(t[:3, :3]))
    return float(np.linalg.norm(t[:3, 3])), float(angle)


def mdh_to_dh(mdh: ArrayLike, reference: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Standard DH table (``beta = 0``) of the arm an MDH table describes.

    Parameters
    ----------
    mdh : array_like, shape (6, 5)
    reference : array_like, shape (6, 5)
        Nominal DH table (branch choices).

    Returns
    -------
    dh : ndarray, shape (6, 5)
        Columns as MDH with ``beta = 0``; nearly parallel axes give large ``d``.
    residual : ndarray, shape (4, 4)
        ``A(mdh)(q) = A(dh)(q) @ residual`` for every q (identity if exact).
    """
    joints, flange = joint_frames(mdh)
    dh, base, residual = fit_links(joints, flange, reference, np.zeros(5, bool))
    # Frame 0 of an MDH table is its base frame, so ``base`` is the identity.
    return dh, base @ residual


def dh_to_mdh(dh: ArrayLike, reference: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """MDH table (Hayati where the reference has parallel axes) of a DH-described arm.

    Parameters
    ----------
    dh : array_like, shape (6, 5)
        Standard DH (or any MDH) table.
    reference : array_like, shape (6, 5)
        Nominal MDH table: branch choices, parallel axes and their ``d``.

    Returns
    -------
    mdh : ndarray, shape (6, 5)
    residual : ndarray, shape (4, 4)
        As in :func:`mdh_to_dh`.
    """
    joints, flange = joint_frames(dh)
    mdh, base, residual = fit_links(
        joints, flange, reference, kinematics.parallel_axes(reference, tol=0.1), beta6=True
    )
    return mdh, base @ residual


def craig_to_mdh(table: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """MDH table and base offset of an arm given in Craig's modified DH.

    Craig's link ``i`` is ``Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i) Tz(d_i)``.
    ``Rx`` and ``Tx`` commute, so the chain regroups exactly into
    ``Rx(alpha_0) Tx(a_0) . A_1 ... A_6`` with MDH links ``A_i = Rz(theta_i)
    Tz(d_i) Tx(a_i) Rx(alpha_i)`` (``beta = 0``) and ``a_6 = alpha_6 = 0``.

    Parameters
    ----------
    table : array_like, shape (6, 3)
        Rows ``[alpha_{i-1} (rad), a_{i-1} (mm), d_i (mm)]``; joint offsets 0.

    Returns
    -------
    base2frame0 : ndarray, shape (4, 4)
        ``Rx(alpha_0) Tx(a_0)``: MDH frame 0 in Craig's base frame (mm).
    mdh : ndarray, shape (6, 5)
    """
    table = np.asarray(table, dtype=float)
    if table.shape != (6, 3):
        raise ValueError(f"Craig DH table must be 6 x 3, got {table.shape}")
    mdh = np.zeros((6, 5))
    mdh[:5, kinematics.A] = table[1:, 1]
    mdh[:5, ALPHA] = table[1:, 0]
    mdh[:, kinematics.D] = table[:, 2]
    # Rx(alpha_0) leaves the x axis where it is: the offset is a_0 along x.
    base2frame0 = frames.transform(
        rotations.rotations_xyz([table[0, 0], 0.0, 0.0]), [table[0, 1], 0, 0]
    )
    return base2frame0, mdh


def standard_dh_to_mdh(table: ArrayLike) -> np.ndarray:
    """MDH table of an arm given in standard DH, up to six joints.

    Standard DH's ``M_i = Rz(theta_i) Tz(s_i) Tx(h_i) Rx(alpha_i)`` is the MDH
    link with ``beta = 0``: only the columns differ. Missing joints (an arm
    of fewer than six) are identity links at the end.

    Parameters
    ----------
    table : array_like, shape (..., n, 4), n <= 6
        Rows ``[theta_offset (rad), s (mm), h (mm), alpha (rad)]``.

    Returns
    -------
    ndarray, shape (..., 6, 5)
    """
    table = np.asarray(table, dtype=float)
    n = table.shape[-2]
    if table.shape[-1] != 4 or not 1 <= n <= 6:
        raise ValueError(f"standard DH table must have shape (..., n <= 6, 4), got {table.shape}")
    mdh = np.zeros(table.shape[:-2] + (6, 5))
    mdh[..., :n, THETA] = table[..., 0]
    mdh[..., :n, kinematics.D] = table[..., 1]
    mdh[..., :n, kinematics.A] = table[..., 2]
    mdh[..., :n, ALPHA] = table[..., 3]
    return mdh
