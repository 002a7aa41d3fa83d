"""Rigid-transform helpers on stacked arrays (mm, rad).

Frames are named ``a2b``: ``base2tracker`` maps coordinates in the robot base
frame to coordinates in the tracker frame (the pose of the base in the
tracker frame).

Rotations themselves (rotation vectors, XYZ angles, the rotation error) are
:mod:`calibrator.model.rotations`.
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
