"""Hayati-modified DH (MDH) kinematics, batched over poses and parameter sets.

One link of the MDH model (the IPSO paper, eq. 1) is::

    A_i = Rz(theta_i + q_i) . Tz(d_i) . Tx(a_i) . Rx(alpha_i) . Ry(beta_i)

and the flange pose in the robot base frame is ``base2flange = A_1 ... A_6``.
A parameter table has shape ``(..., 6, 5)`` with columns
``[a_mm, alpha_rad, theta_rad, d_mm, beta_rad]`` (see :data:`COLUMNS`);
the leading ``...`` is any batch of parameter sets (e.g. a particle swarm).
Joint angles have shape ``(N, 6)`` in radians. Lengths are millimetres.

Every function here is a plain function on numpy arrays with no loop over
poses or parameter sets: the only Python loop is over the six links.
"""

from __future__ import annotations

import math
from typing import Literal, overload

import numpy as np
from numpy.typing import ArrayLike

#: Column order of an MDH parameter table.
COLUMNS = ("a", "alpha", "theta", "d", "beta")
#: Units of the columns of an MDH parameter table, in :data:`COLUMNS` order.
UNITS = ("mm", "rad", "rad", "mm", "rad")
#: Field names of the columns with their units, as in files: ``a_mm, alpha_rad, ...``.
FIELDS = tuple(f"{c}_{u}" for c, u in zip(COLUMNS, UNITS, strict=True))
A, ALPHA, THETA, D, BETA = range(5)
N_JOINTS = 6
#: Names of the entries of an MDH table, row by row: ``a1, alpha1, ..., beta6``.
MDH_NAMES = tuple(f"{col}{j + 1}" for j in range(N_JOINTS) for col in COLUMNS)
_EYE_TOP = np.eye(4)[:3]


def check_mdh(mdh: ArrayLike) -> np.ndarray:
    """Return ``mdh`` as a float array of shape ``(..., 6, 5)`` or raise ValueError."""
    mdh = np.asarray(mdh, dtype=float)
    if mdh.ndim < 2 or mdh.shape[-2:] != (N_JOINTS, 5):
        raise ValueError(f"MDH table must have shape (..., 6, 5), got {mdh.shape}")
    return mdh


def check_joints(q: ArrayLike) -> np.ndarray:
    """Return ``q`` as a float array of shape ``(N, 6)`` (rad) or raise ValueError."""
    q = np.asarray(q, dtype=float)
    if q.ndim == 1:
        q = q[np.newaxis]
    if q.ndim != 2 or q.shape[1] != N_JOINTS:
        raise ValueError(f"joint angles must have shape (N, 6), got {q.shape}")
    return q


def link_constants(mdh: ArrayLike) -> np.ndarray:
    """The pose-independent part of each link, ``Tz(d) Tx(a) Rx(alpha) Ry(beta)``.

    Parameters
    ----------
    mdh : array_like, shape (..., 6, 5)
        MDH tables (mm, rad).

    Returns
    -------
    ndarray, shape (..., 6, 4, 4)
        Homogeneous transforms (mm) from the frame after ``Rz(theta_i + q_i)``
        to link frame i.
    """
    mdh = check_mdh(mdh)
    ca, sa = np.cos(mdh[..., ALPHA]), np.sin(mdh[..., ALPHA])
    cb, sb = np.cos(mdh[..., BETA]), np.sin(mdh[..., BETA])
    out = np.zeros(mdh.shape[:-1] + (4, 4))
    # Rx(alpha) @ Ry(beta), written out.
    out[..., 0, 0] = cb
    out[..., 0, 2] = sb
    out[..., 1, 0] = sa * sb
    out[..., 1, 1] = ca
    out[..., 1, 2] = -sa * cb
    out[..., 2, 0] = -ca * sb
    out[..., 2, 1] = sa
    out[..., 2, 2] = ca * cb
    out[..., 0, 3] = mdh[..., A]
    out[..., 2, 3] = mdh[..., D]
    out[..., 3, 3] = 1.0
    return out


def joint_phases(angles: ArrayLike) -> np.ndarray:
    """``exp(-1j * angles)``: the form in which :func:`chain_parts` takes rotations about z.

    Parameters
    ----------
    angles : array_like, shape (...)
        Joint angles or joint offsets theta (rad).

    Returns
    -------
    ndarray of complex, same shape
    """
    return np.exp(-1j * np.asarray(angles, dtype=float))


def chain_parts(
    consts: np.ndarray,
    theta_phase: np.ndarray,
    q_phase: np.ndarray,
    *,
    all_frames: bool = False,
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """Forward kinematics from precomputed parts; the fast path of :func:`chain`.

    A caller that evaluates many parameter sets on the same poses (the
    identifier) computes ``q_phase`` once and passes it every time.

    Parameters
    ----------
    consts : ndarray, shape (..., 6, 4, 4)
        :func:`link_constants` of the tables.
    theta_phase : ndarray of complex, shape (..., 6)
        ``joint_phases(mdh[..., THETA])``.
    q_phase : ndarray of complex, shape (N, 6)
        ``joint_phases(q)``.
    all_frames : bool
        Also return the frame of every link.

    Notes
    -----
    ``t @ Rz(phi)`` mixes only columns 0 and 1 of ``t``; they sit side by
    side in memory, so viewed as complex numbers ``col0 + 1j*col1`` the
    rotation is one multiply by ``exp(-1j*phi)`` instead of a 4x4 product.

    Returns
    -------
    base2flange : ndarray, shape (..., N, 3, 4)
        Top three rows of the flange pose in the base frame (mm).
    frames : ndarray, shape (..., N, 7, 3, 4)
        Only with ``all_frames``: top rows of ``A_1 ... A_i`` for i = 0..6.
    """
    batch = consts.shape[:-3]
    n = q_phase.shape[0]
    flat = math.prod(batch)
    consts = consts.reshape((flat, 6, 4, 4))
    theta_phase = theta_phase.reshape(flat, 6)
    # The phase of theta_i + q_i for every joint, set and pose, one product up
    # front, made contiguous per joint, (6, sets, N, 1): 9 % less time than
    # one outer product per joint, and the same numbers (measured).
    phases = np.ascontiguousarray((theta_phase[:, np.newaxis, :] * q_phase).transpose(2, 0, 1))
    phases = phases[..., np.newaxis]
    t = np.empty((flat, n, 3, 4))
    t[...] = _EYE_TOP
    spare = np.empty_like(t)
    # The rotation below works in place, so stored frames must be copies.
    frames = [t.copy()] if all_frames else []
    for i in range(N_JOINTS):
        t.view(np.complex128)[..., 0] *= phases[i]
        # One matrix product per parameter set over all poses' rows at once:
        # numpy then makes a few large products instead of N*sets tiny ones.
        # Into a preallocated buffer: the loop allocates nothing per joint.
        np.matmul(t.reshape(flat, n * 3, 4), consts[:, i], out=spare.reshape(flat, n * 3, 4))
        t, spare = spare, t
        if all_frames:
            frames.append(t.copy())
    shape = batch + (n, 3, 4)
    if all_frames:
        return t.reshape(shape), np.stack(frames, axis=-3).reshape(batch + (n, 7, 3, 4))
    return t.reshape(shape)


def _homogeneous(top):
    """Append the row ``[0, 0, 0, 1]`` to stacked 3x4 transforms."""
    out = np.zeros(top.shape[:-2] + (4, 4))
    out[..., :3, :] = top
    out[..., 3, 3] = 1.0
    return out


@overload
def chain(mdh: ArrayLike, q: ArrayLike, *, all_frames: Literal[False] = ...) -> np.ndarray: ...
@overload
def chain(
    mdh: ArrayLike, q: ArrayLike, *, all_frames: Literal[True]
) -> tuple[np.ndarray, np.ndarray]: ...
def chain(
    mdh: ArrayLike, q: ArrayLike, *, all_frames: bool = False
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """Forward kinematics of the arm, base to flange.

    Parameters
    ----------
    mdh : array_like, shape (..., 6, 5)
        MDH tables (mm, rad); ``...`` is a batch of parameter sets.
    q : array_like, shape (N, 6)
        Joint angles (rad).
    all_frames : bool
        Also return the frame of every link.

    Returns
    -------
    base2flange : ndarray, shape (..., N, 4, 4)
        Flange pose in the robot base frame (mm).
    frames : ndarray, shape (..., N, 7, 4, 4)
        Only with ``all_frames``: ``frames[..., i, :, :]`` is ``A_1 ... A_i``
        (index 0 is the identity, index 6 the flange).
    """
    mdh = check_mdh(mdh)
    q = check_joints(q)
    out = chain_parts(
        link_constants(mdh), joint_phases(mdh[..., THETA]), joint_phases(q), all_frames=all_frames
    )
    if all_frames:
        return _homogeneous(out[0]), _homogeneous(out[1])
    return _homogeneous(out)


def forward(
    mdh: ArrayLike,
    q: ArrayLike,
    flange2tool: ArrayLike | None = None,
    base2tracker: ArrayLike | None = None,
) -> np.ndarray:
    """Tool pose for each parameter set and pose: ``base2tracker . A_1...A_6 . flange2tool``.

    Parameters
    ----------
    mdh : array_like, shape (..., 6, 5)
        MDH tables (mm, rad).
    q : array_like, shape (N, 6)
        Joint angles (rad).
    flange2tool : array_like, shape (..., 4, 4), optional
        Tool frame in the flange frame (mm); identity if omitted.
    base2tracker : array_like, shape (..., 4, 4), optional
        Robot base frame in the tracker frame (mm); identity if omitted.

    Returns
    -------
    ndarray, shape (..., N, 4, 4)
        Tool pose in the tracker frame (the base frame without ``base2tracker``).
    """
    t = chain(mdh, q)
    if flange2tool is not None:
        t = t @ np.asarray(flange2tool, dtype=float)[..., np.newaxis, :, :]
    if base2tracker is not None:
        t = np.asarray(base2tracker, dtype=float)[..., np.newaxis, :, :] @ t
    return t


def tool_poses(mdh: ArrayLike, q: ArrayLike, flange2tool: ArrayLike) -> np.ndarray:
    """Tool poses in the base frame, one per joint vector.

    Parameters
    ----------
    mdh : array_like, shape (6, 5)
    q : array_like, shape (N, 6)
        Joint angles (rad).
    flange2tool : array_like, shape (4, 4) or (N, 4, 4)
        One tool for every pose, or one per pose (unlike :func:`forward`,
        which broadcasts a stack of tools against every pose).

    Returns
    -------
    ndarray, shape (N, 4, 4)
        Tool poses, base frame (mm).
    """
    return chain(mdh, q) @ flange2tool


def joint_origins(mdh: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """The chain regrouped at the joints: each joint's frame before it turns.

    ``A_i = Rz(theta_i + q_i) Tz(d_i) . T_i`` with ``T_i = Tx(a_i) Rx(alpha_i)
    Ry(beta_i)``; since ``Rz(q_i)`` commutes with ``Tz(d_i)``::

        A_1 ... A_6 (q) = O_1 Rz(q_1) ... O_6 Rz(q_6) . T_6,
        O_i = T_{i-1} Rz(theta_i) Tz(d_i),  T_0 = I.

    ``O_i`` places joint i (z on its axis, origin on it) in the frame of the
    joint before: the form of ROS and URDF joint origins, and of the posed
    arms of :mod:`calibrator.analysis.arm`, where an error transform is
    inserted at each joint.

    Parameters
    ----------
    mdh : array_like, shape (..., 6, 5)
        MDH tables (mm, rad), each turned to its pose if ``theta`` holds one.

    Returns
    -------
    origins : ndarray, shape (..., 6, 4, 4)
        ``O_i`` (mm).
    trailing : ndarray, shape (..., 4, 4)
        ``T_6``, joint 6's frame after it turns to the flange frame (mm).
    """
    mdh = check_mdh(mdh)
    tails = link_constants(mdh)  # Tz(d) Tx(a) Rx(alpha) Ry(beta), with the Tz taken out below
    tails[..., 2, 3] -= mdh[..., D]
    heads = np.zeros_like(tails)  # Rz(theta_i) Tz(d_i)
    c, s = np.cos(mdh[..., THETA]), np.sin(mdh[..., THETA])
    heads[..., 0, 0], heads[..., 0, 1], heads[..., 1, 0], heads[..., 1, 1] = c, -s, s, c
    heads[..., 2, 2] = heads[..., 3, 3] = 1.0
    heads[..., 2, 3] = mdh[..., D]
    before = np.concatenate(
        [np.broadcast_to(np.eye(4), tails[..., :1, :, :].shape), tails[..., :5, :, :]], axis=-3
    )
    return before @ heads, tails[..., 5, :, :]


def parallel_axes(mdh: ArrayLike, tol: float = 1e-6) -> np.ndarray:
    """Which consecutive joint axes are parallel in a nominal table.

    Axis i+1 is parallel to axis i when ``alpha_i`` (and ``beta_i``) is 0 or
    pi; there ``d_i`` slides the common normal along parallel axes and is not
    identifiable, and Hayati's ``beta_i`` is identified instead.

    Parameters
    ----------
    mdh : array_like, shape (6, 5)
    tol : float
        Tolerance on the angle between the axes (rad).

    Returns
    -------
    ndarray of bool, shape (5,)
        Element i-1 tells whether axes i and i+1 are parallel (i = 1..5).
    """
    mdh = check_mdh(mdh)
    # z axis of link frame i in the frame after Rz(theta_i + q_i): its z
    # component is the cosine of the angle between axes i and i+1.
    cos_angle = np.abs(link_constants(mdh)[..., :5, 2, 2])
    return cos_angle > np.cos(tol)
