"""Rotations in every notation the project reads or writes, vectorised.

The one rotation module: :mod:`calibrator.model.frames` builds rigid
transforms from these, and robot programs, exports and tracker drivers
convert through them.

- Rotation vectors (rad; axis times angle): :func:`rotvec_to_matrix`,
  :func:`matrix_to_rotvec`, and :func:`rotation_error` (the rotation vector
  between two orientations).
- XYZ angles (rad, about the moving x, then y, then z):
  :func:`rotations_xyz`, :func:`angles_xyz`.
- ZYX Euler angles (deg; KUKA's A, B, C; Fanuc's W, P, R and Yaskawa's Rx,
  Ry, Rz are the same rotation written in another order): ``R = Rz(a) Ry(b)
  Rx(c)``, A about Z, then B about the new Y, then C about the new X
  (equivalently C about the fixed X, B about the fixed Y, A about the fixed
  Z): :func:`zyx_to_matrix`, :func:`matrix_to_zyx`.
- Quaternions ``[w, x, y, z]`` (ABB's ``[q1, q2, q3, q4]``, emScon's
  scalar-first ones): :func:`quaternion_to_matrix`,
  :func:`matrix_to_quaternion`, :func:`quaternion_to_rotvec`,
  :func:`rotvec_to_quaternion`.

Writing an orientation back in a program's notation picks, of the
notation's equivalent forms, the one closest to what the program had, so
that a corrected target keeps the look (signs, branches) of the original.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike


def rotvec_to_matrix(rotvec: ArrayLike) -> np.ndarray:
    """Rotation vectors (..., 3) rad to rotation matrices (..., 3, 3) (Rodrigues)."""
    rotvec = np.asarray(rotvec, dtype=float)
    angle = np.linalg.norm(rotvec, axis=-1)[..., np.newaxis, np.newaxis]
    k = _skew(rotvec)
    small = angle < 1e-6
    safe = np.where(small, 1.0, angle)
    # Taylor series below 1e-6 rad, where sin(t)/t and (1-cos t)/t^2 lose digits.
    a = np.where(small, 1.0 - angle**2 / 6.0, np.sin(safe) / safe)
    b = np.where(small, 0.5 - angle**2 / 24.0, (1.0 - np.cos(safe)) / safe**2)
    return np.eye(3) + a * k + b * (k @ k)


def matrix_to_rotvec(matrix: ArrayLike) -> np.ndarray:
    """Rotation matrices (..., 3, 3) to rotation vectors (..., 3) rad, angle in [0, pi].

    Goes through a unit quaternion (Shepperd's choice of the largest
    component), which stays accurate near 0 and near pi.
    """
    r = np.asarray(matrix, dtype=float)
    trace = np.trace(r, axis1=-2, axis2=-1)
    diag = np.diagonal(r, axis1=-2, axis2=-1)
    choice = np.argmax(np.concatenate([trace[..., None], diag], axis=-1), axis=-1)
    quat = np.empty(r.shape[:-2] + (4,))  # (x, y, z, w)
    w_case = choice == 0
    t = np.sqrt(np.maximum(1.0 + trace, 1e-300))
    quat[..., 3] = np.where(w_case, 0.5 * t, 0.0)
    for i in range(3):
        j, k = (i + 1) % 3, (i + 2) % 3
        quat[..., i] = np.where(w_case, 0.5 * (r[..., k, j] - r[..., j, k]) / t, 0.0)
    for i in range(3):
        j, k = (i + 1) % 3, (i + 2) % 3
        case = choice == i + 1
        s = np.sqrt(np.maximum(1.0 + 2.0 * r[..., i, i] - trace, 1e-300))
        quat[..., i] = np.where(case, 0.5 * s, quat[..., i])
        quat[..., j] = np.where(case, 0.5 * (r[..., j, i] + r[..., i, j]) / s, quat[..., j])
        quat[..., k] = np.where(case, 0.5 * (r[..., k, i] + r[..., i, k]) / s, quat[..., k])
        quat[..., 3] = np.where(case, 0.5 * (r[..., k, j] - r[..., j, k]) / s, quat[..., 3])
    quat *= np.where(quat[..., 3:] < 0, -1.0, 1.0)
    quat /= np.linalg.norm(quat, axis=-1, keepdims=True)
    v = np.linalg.norm(quat[..., :3], axis=-1, keepdims=True)
    angle = 2.0 * np.arctan2(v, quat[..., 3:])
    scale = np.where(
        v < 1e-12, 2.0 / np.maximum(quat[..., 3:], 1e-300), angle / np.maximum(v, 1e-300)
    )
    return quat[..., :3] * scale


def _skew(v):
    out = np.zeros(v.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out


def rotation_error(model: ArrayLike, measured: ArrayLike) -> np.ndarray:
    """Rotation vector (rad) of ``model @ measured.T``: how far the model is turned.

    Parameters
    ----------
    model, measured : array_like, shape (..., 3, 3)
        Orientations in the same frame.

    Returns
    -------
    ndarray, shape (..., 3)
        Components along that frame's x, y, z axes (rad).
    """
    return matrix_to_rotvec(np.asarray(model) @ np.swapaxes(np.asarray(measured), -1, -2))


def rotations_xyz(angles: ArrayLike) -> np.ndarray:
    """``Rx(rx) @ Ry(ry) @ Rz(rz)`` for stacked angle triples.

    Parameters
    ----------
    angles : array_like, shape (..., 3)
        ``(rx, ry, rz)`` in rad, applied about the moving frame's x, then y, then z.

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    angles = np.asarray(angles, dtype=float)
    c, s = np.cos(angles), np.sin(angles)
    cx, cy, cz = c[..., 0], c[..., 1], c[..., 2]
    sx, sy, sz = s[..., 0], s[..., 1], s[..., 2]
    out = np.empty(angles.shape[:-1] + (3, 3))
    out[..., 0, 0] = cy * cz
    out[..., 0, 1] = -cy * sz
    out[..., 0, 2] = sy
    out[..., 1, 0] = cx * sz + sx * sy * cz
    out[..., 1, 1] = cx * cz - sx * sy * sz
    out[..., 1, 2] = -sx * cy
    out[..., 2, 0] = sx * sz - cx * sy * cz
    out[..., 2, 1] = sx * cz + cx * sy * sz
    out[..., 2, 2] = cx * cy
    return out


def angles_xyz(rotation: ArrayLike) -> np.ndarray:
    """Inverse of :func:`rotations_xyz`: (..., 3, 3) -> (..., 3) rad, ``ry`` in [-pi/2, pi/2]."""
    r = np.asarray(rotation, dtype=float)
    rx = np.arctan2(-r[..., 1, 2], r[..., 2, 2])
    ry = np.arctan2(r[..., 0, 2], np.hypot(r[..., 0, 0], r[..., 0, 1]))
    rz = np.arctan2(-r[..., 0, 1], r[..., 0, 0])
    return np.stack([rx, ry, rz], axis=-1)


def zyx_to_matrix(abc_deg: ArrayLike) -> np.ndarray:
    """``Rz(a) Ry(b) Rx(c)`` for angles (N, 3) in degrees -> (N, 3, 3)."""
    a, b, c = np.radians(np.asarray(abc_deg, dtype=float)).T
    ca, sa, cb, sb, cc, sc = np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(c), np.sin(c)
    out = np.empty((len(a), 3, 3))
    out[:, 0, 0] = ca * cb
    out[:, 0, 1] = ca * sb * sc - sa * cc
    out[:, 0, 2] = ca * sb * cc + sa * sc
    out[:, 1, 0] = sa * cb
    out[:, 1, 1] = sa * sb * sc + ca * cc
    out[:, 1, 2] = sa * sb * cc - ca * sc
    out[:, 2, 0] = -sb
    out[:, 2, 1] = cb * sc
    out[:, 2, 2] = cb * cc
    return out


def _wrap_near(angle, near):
    return near + (angle - near + 180.0) % 360.0 - 180.0


def matrix_to_zyx(rotation: ArrayLike, near_deg: ArrayLike) -> np.ndarray:
    """ZYX angles (N, 3) deg of rotations (N, 3, 3), the form closest to ``near_deg``.

    Of the two solutions ``(a, b, c)`` and ``(a + 180, 180 - b, c + 180)``,
    each angle wrapped to within 180 deg of ``near_deg``, the one with the
    smaller largest change is returned.
    """
    r = np.asarray(rotation, dtype=float)
    near = np.asarray(near_deg, dtype=float)
    b = np.degrees(np.arctan2(-r[:, 2, 0], np.hypot(r[:, 0, 0], r[:, 1, 0])))
    a = np.degrees(np.arctan2(r[:, 1, 0], r[:, 0, 0]))
    c = np.degrees(np.arctan2(r[:, 2, 1], r[:, 2, 2]))
    first = np.column_stack([a, b, c])
    second = np.column_stack([a + 180.0, 180.0 - b, c + 180.0])
    first = _wrap_near(first, near)
    second = _wrap_near(second, near)
    pick = np.max(np.abs(second - near), axis=1) < np.max(np.abs(first - near), axis=1)
    return np.where(pick[:, None], second, first)


def quaternion_to_matrix(wxyz: ArrayLike) -> np.ndarray:
    """Rotations (N, 3, 3) of quaternions (N, 4) ``[w, x, y, z]`` (normalised first)."""
    q = np.asarray(wxyz, dtype=float)
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    w, x, y, z = q.T
    out = np.empty((len(q), 3, 3))
    out[:, 0] = np.column_stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)])
    out[:, 1] = np.column_stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)])
    out[:, 2] = np.column_stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)])
    return out


def matrix_to_quaternion(rotation: ArrayLike, near: ArrayLike) -> np.ndarray:
    """Unit quaternions (N, 4) ``[w, x, y, z]`` of rotations, signed like ``near``."""
    r = np.asarray(rotation, dtype=float)
    trace = np.trace(r, axis1=1, axis2=2)
    cand = np.stack(
        [
            np.column_stack(
                [
                    1 + trace,
                    r[:, 2, 1] - r[:, 1, 2],
                    r[:, 0, 2] - r[:, 2, 0],
                    r[:, 1, 0] - r[:, 0, 1],
                ]
            ),
            np.column_stack(
                [
                    r[:, 2, 1] - r[:, 1, 2],
                    1 + r[:, 0, 0] - r[:, 1, 1] - r[:, 2, 2],
                    r[:, 0, 1] + r[:, 1, 0],
                    r[:, 0, 2] + r[:, 2, 0],
                ]
            ),
            np.column_stack(
                [
                    r[:, 0, 2] - r[:, 2, 0],
                    r[:, 0, 1] + r[:, 1, 0],
                    1 - r[:, 0, 0] + r[:, 1, 1] - r[:, 2, 2],
                    r[:, 1, 2] + r[:, 2, 1],
                ]
            ),
            np.column_stack(
                [
                    r[:, 1, 0] - r[:, 0, 1],
                    r[:, 0, 2] + r[:, 2, 0],
                    r[:, 1, 2] + r[:, 2, 1],
                    1 - r[:, 0, 0] - r[:, 1, 1] + r[:, 2, 2],
                ]
            ),
        ],
        axis=1,
    )  # (N, 4 candidates, 4): row k is 4 q_k * q, best conditioned for the largest q_k
    diag = np.column_stack([trace, r[:, 0, 0], r[:, 1, 1], r[:, 2, 2]])
    best = cand[np.arange(len(r)), np.argmax(diag, axis=1)]
    q = best / np.linalg.norm(best, axis=1, keepdims=True)
    sign = np.where(np.einsum("ij,ij->i", q, np.asarray(near, dtype=float)) < 0, -1.0, 1.0)
    return q * sign[:, None]


def quaternion_to_rotvec(wxyz: ArrayLike) -> np.ndarray:
    """Rotation vectors (N, 3) rad of scalar-first quaternions (N, 4), normalised first.

    ``q`` and ``-q`` are one rotation: the one with the angle in [0, pi] is
    taken. A zero or non-finite quaternion gives a row of NaN, for the caller
    to refuse.
    """
    q = np.asarray(wxyz, dtype=float).reshape(-1, 4)
    norm = _row_norms(q)[:, None]
    good = np.isfinite(norm[:, 0]) & (norm[:, 0] > 0)
    q = np.where(good[:, None], q / np.where(good[:, None], norm, 1.0), np.nan)
    q = np.where(q[:, :1] < 0, -q, q)
    w, v = q[:, 0], q[:, 1:]
    s = _row_norms(v)[:, None]
    small = s < 1e-12
    # 2 atan2(s, w) / s -> 2 as the angle vanishes (the small-angle limit).
    return np.where(small, 2.0 * v, 2.0 * np.arctan2(s, w[:, None]) * v / np.where(small, 1.0, s))


def rotvec_to_quaternion(rotvec: ArrayLike) -> np.ndarray:
    """Scalar-first unit quaternions (N, 4) ``[w, x, y, z]`` of rotation vectors (N, 3) rad."""
    v = np.asarray(rotvec, dtype=float).reshape(-1, 3)
    angle = _row_norms(v)
    axis = v / np.where(angle > 0, angle, 1.0)[:, None]
    return np.column_stack([np.cos(angle / 2), np.sin(angle / 2)[:, None] * axis])


def _row_norms(x: np.ndarray) -> np.ndarray:
    """Euclidean norm of each row of ``x`` (N, k), as ``np.linalg.norm`` gives it for one row.

    A batched dot product, not ``norm(axis=1)`` (whose sum rounds differently
    in the last bit): a tracker reading converted alone or in a batch is the
    same to the bit.
    """
    return np.sqrt((x[:, None, :] @ x[:, :, None])[:, 0, 0])
