"""Rigid-transform helpers on stacked arrays (mm, rad).

Frames are named ``a2b``: ``base2tracker`` maps coordinates in the robot base
frame to coordinates in the tracker frame (the pose of the base in the
tracker frame).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike


def check_transform(t: ArrayLike, name: str = "transform") -> np.ndarray:
    """Return ``t`` as a float (4, 4) homogeneous transform or raise ValueError."""
    t = np.asarray(t, dtype=float)
    if t.shape != (4, 4):
        raise ValueError(f"{name} must have shape (4, 4), got {t.shape}")
    if not np.allclose(t[3], [0, 0, 0, 1]):
        raise ValueError(f"{name} must have a last row [0, 0, 0, 1]")
    r = t[:3, :3]
    if not np.allclose(r @ r.T, np.eye(3), atol=1e-6) or np.linalg.det(r) < 0:
        raise ValueError(f"{name} rotation part is not a proper rotation")
    return t


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


def transform(
    rotation: ArrayLike | None = None, translation: ArrayLike | None = None
) -> np.ndarray:
    """Stack rotations (..., 3, 3) and translations (..., 3) into (..., 4, 4) transforms."""
    rotation = np.eye(3) if rotation is None else np.asarray(rotation, dtype=float)
    translation = np.zeros(3) if translation is None else np.asarray(translation, dtype=float)
    batch = np.broadcast_shapes(rotation.shape[:-2], translation.shape[:-1])
    out = np.zeros(batch + (4, 4))
    out[..., :3, :3] = rotation
    out[..., :3, 3] = translation
    out[..., 3, 3] = 1.0
    return out


def xyz_rpy(transform: ArrayLike) -> np.ndarray:
    """``x y z`` (mm) and URDF ``roll pitch yaw`` (rad, ``Rz(yaw) Ry(pitch) Rx(roll)``) of a (4, 4).

    The ``<origin xyz rpy>`` of a URDF joint and the ROS kinematics YAML's
    joint origins; :func:`from_xyz_rpy` is its inverse.
    """
    from scipy.spatial.transform import Rotation

    t = np.asarray(transform, dtype=float)
    rpy = Rotation.from_matrix(t[:3, :3]).as_euler("xyz")
    return np.concatenate([t[:3, 3], rpy])


def from_xyz_rpy(values: ArrayLike) -> np.ndarray:
    """Inverse of :func:`xyz_rpy`: (x, y, z mm, roll, pitch, yaw rad) -> (4, 4)."""
    from scipy.spatial.transform import Rotation

    values = np.asarray(values, dtype=float)
    out = np.eye(4)
    out[:3, :3] = Rotation.from_euler("xyz", values[3:]).as_matrix()
    out[:3, 3] = values[:3]
    return out


def invert(t: ArrayLike) -> np.ndarray:
    """Inverse of stacked rigid transforms (..., 4, 4)."""
    t = np.asarray(t, dtype=float)
    r_t = np.swapaxes(t[..., :3, :3], -1, -2)
    return transform(r_t, -(r_t @ t[..., :3, 3:4])[..., 0])


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


def fit_rigid(source: ArrayLike, target: ArrayLike) -> np.ndarray:
    """Best-fit rigid transform mapping ``source`` points onto ``target`` (Kabsch).

    Parameters
    ----------
    source, target : array_like, shape (N, 3)
        Corresponding points (mm), N >= 3 and not all on a line.

    Returns
    -------
    ndarray, shape (4, 4)
        ``source2target`` minimising the summed squared distances.
    """
    source = np.asarray(source, dtype=float)
    target = np.asarray(target, dtype=float)
    cs, ct = source.mean(axis=0), target.mean(axis=0)
    h = (source - cs).T @ (target - ct)
    u, _, vt = np.linalg.svd(h)
    # The sign fix keeps a proper rotation when the best orthogonal fit is a reflection.
    fix = np.diag([1.0, 1.0, np.sign(np.linalg.det(vt.T @ u.T))])
    r = vt.T @ fix @ u.T
    return transform(r, ct - r @ cs)
