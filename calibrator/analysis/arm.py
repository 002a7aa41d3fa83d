"""An arm at one pose as a chain of constant link transforms, ready for error insertion.

Both conventions in use reduce to the same form at a fixed pose::

    base2hand = L_1 . L_2 . ... . L_6 . F,   L_i = B_i . Rz(q_i) . Tz(d_i)

where the frame at the end of ``L_i`` (the *joint frame* i) has its z axis on
joint i's axis and its origin on that axis; an error transform ``E_i`` of
joint i is inserted right there: ``L_1 E_1 L_2 E_2 ... L_6 E_6 F``.

- Craig's modified DH (the misalignment paper's arm, columns
  ``alpha_{i-1}, a_{i-1}, d_i``): ``B_i = Rx(alpha_{i-1}) Tx(a_{i-1})``, ``F = I``.
- This project's Hayati MDH tables (:mod:`calibrator.model.kinematics`):
  ``A_i = Rz(theta_i + q_i) Tz(d_i) . Tx(a_i) Rx(alpha_i) Ry(beta_i)``, so
  ``B_1 = I``, ``B_{i+1}`` and ``F`` are the ``Tx Rx Ry`` tail of the previous link.

All transforms are stored as their top three rows, shape ``(..., 3, 4)`` (mm).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from calibrator.errors import CalibrationError
from calibrator.model import kinematics
from calibrator.robots import misalignment_paper

_DEG = np.pi / 180.0

#: The misalignment paper's arm (its Table 2), Craig modified DH:
#: rows ``[alpha_{i-1} (deg), a_{i-1} (mm), d_i (mm)]``.
PAPER_CRAIG = misalignment_paper.CRAIG_TABLE
#: The paper's pose, joint angles theta_1..6 (deg).
PAPER_POSE_DEG = misalignment_paper.POSE_DEG


def rot_x(angle: ArrayLike) -> np.ndarray:
    """Top rows of Rx(angle), shape ``angle.shape + (3, 4)``."""
    c, s = np.cos(angle), np.sin(angle)
    out = np.zeros(np.shape(angle) + (3, 4))
    out[..., 0, 0] = 1.0
    out[..., 1, 1], out[..., 1, 2] = c, -s
    out[..., 2, 1], out[..., 2, 2] = s, c
    return out


def rot_y(angle: ArrayLike) -> np.ndarray:
    """Top rows of Ry(angle)."""
    c, s = np.cos(angle), np.sin(angle)
    out = np.zeros(np.shape(angle) + (3, 4))
    out[..., 1, 1] = 1.0
    out[..., 0, 0], out[..., 0, 2] = c, s
    out[..., 2, 0], out[..., 2, 2] = -s, c
    return out


def rot_z(angle: ArrayLike) -> np.ndarray:
    """Top rows of Rz(angle)."""
    c, s = np.cos(angle), np.sin(angle)
    out = np.zeros(np.shape(angle) + (3, 4))
    out[..., 2, 2] = 1.0
    out[..., 0, 0], out[..., 0, 1] = c, -s
    out[..., 1, 0], out[..., 1, 1] = s, c
    return out


def trans(x: ArrayLike, y: ArrayLike, z: ArrayLike) -> np.ndarray:
    """Top rows of Trans(x, y, z) (mm); arguments broadcast."""
    x, y, z = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (x, y, z)))
    out = np.zeros(x.shape + (3, 4))
    out[..., 0, 0] = out[..., 1, 1] = out[..., 2, 2] = 1.0
    out[..., 0, 3], out[..., 1, 3], out[..., 2, 3] = x, y, z
    return out


def compose(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a . b`` for stacked 3x4 rigid transforms (broadcast over leading axes).

    Written as elementwise multiply-adds rather than ``matmul`` on purpose:
    each output element is then computed the same way whatever the batch
    size, array layout or BLAS threading, which is what keeps Monte Carlo
    results bit-identical across chunkings and machines with the same numpy.
    """
    out = a[..., :, 0:1] * b[..., 0:1, :]
    out = out + a[..., :, 1:2] * b[..., 1:2, :]
    out = out + a[..., :, 2:3] * b[..., 2:3, :]
    out[..., 3] += a[..., 3]
    return out


@dataclass(frozen=True)
class PosedArm:
    """An arm at one pose, as the constant link transforms of the module docstring.

    Attributes
    ----------
    links : ndarray, shape (6, 3, 4)
        ``L_i = B_i Rz(q_i) Tz(d_i)``, joint frame i-1 to joint frame i (mm).
    tail : ndarray, shape (3, 4)
        ``F``, joint frame 6 to the hand frame (mm).
    name : str
        What the arm is, for reports.
    """

    links: np.ndarray
    tail: np.ndarray
    name: str = ""

    def base2hand(self) -> np.ndarray:
        """The ideal hand pose, shape (3, 4) (mm)."""
        t = self.links[0]
        for link in self.links[1:]:
            t = compose(t, link)
        return compose(t, self.tail)

    def joint_frames(self) -> np.ndarray:
        """Ideal base-to-joint-frame transforms, shape (6, 3, 4): ``L_1 ... L_i``."""
        out = [self.links[0]]
        for link in self.links[1:]:
            out.append(compose(out[-1], link))
        return np.stack(out)


def craig_arm(table: ArrayLike, pose_rad: ArrayLike, name: str = "craig") -> PosedArm:
    """A :class:`PosedArm` from a Craig modified-DH table.

    Parameters
    ----------
    table : array_like, shape (6, 3)
        Rows ``[alpha_{i-1} (rad), a_{i-1} (mm), d_i (mm)]``.
    pose_rad : array_like, shape (6,)
        Joint angles theta_i (rad).
    """
    table = np.asarray(table, dtype=float)
    q = _check_pose(pose_rad)
    if table.shape != (6, 3):
        raise CalibrationError(f"Craig DH table must be 6 x 3, got {table.shape}")
    links = compose(
        compose(rot_x(table[:, 0]), trans(table[:, 1], 0.0, 0.0)),
        compose(rot_z(q), trans(0.0, 0.0, table[:, 2])),
    )
    return PosedArm(links=links, tail=trans(0.0, 0.0, 0.0), name=name)


def mdh_arm(mdh: ArrayLike, pose_rad: ArrayLike, name: str = "mdh") -> PosedArm:
    """A :class:`PosedArm` from a Hayati MDH table (:mod:`calibrator.model.kinematics`).

    Parameters
    ----------
    mdh : array_like, shape (6, 5)
        ``[a_mm, alpha_rad, theta_rad, d_mm, beta_rad]`` per joint.
    pose_rad : array_like, shape (6,)
        Joint angles q (rad); joint i turns by ``theta_i + q_i``.
    """
    try:
        mdh = kinematics.check_mdh(mdh)
    except ValueError as exc:
        raise CalibrationError(str(exc)) from None
    q = _check_pose(pose_rad)
    k = kinematics
    tails = compose(
        compose(trans(mdh[:, k.A], 0.0, 0.0), rot_x(mdh[:, k.ALPHA])), rot_y(mdh[:, k.BETA])
    )
    heads = np.concatenate([trans(0.0, 0.0, 0.0)[np.newaxis], tails[:5]])
    links = compose(heads, compose(rot_z(mdh[:, k.THETA] + q), trans(0.0, 0.0, mdh[:, k.D])))
    return PosedArm(links=links, tail=tails[5], name=name)


def _check_pose(pose):
    pose = np.asarray(pose, dtype=float)
    if pose.shape != (6,) or not np.all(np.isfinite(pose)):
        raise CalibrationError(f"a pose is six finite joint angles, got shape {pose.shape}")
    return pose


#: Name of the built-in arm in :func:`build`.
PAPER = "paper"


def length_names(model: str) -> tuple[str, ...]:
    """Link lengths :func:`build` can set, by name, for a model (``'paper'`` or a named model)."""
    if model == PAPER:
        return tuple(f"a{i}" for i in range(6)) + tuple(f"d{i + 1}" for i in range(6))
    return tuple(f"a{i + 1}" for i in range(6)) + tuple(f"d{i + 1}" for i in range(6))


def build(
    model: str = PAPER,
    pose_deg: ArrayLike | None = None,
    lengths: Mapping[str, float] | None = None,
) -> PosedArm:
    """A posed arm by name, optionally with some link lengths changed.

    Parameters
    ----------
    model : str
        ``'paper'`` (the misalignment paper's arm, Craig DH: lengths ``a0..a5``
        are ``a_{i-1}``, ``d1..d6`` are ``d_i``) or a name known to
        :func:`calibrator.robots.get` (Hayati MDH: ``a1..a6``, ``d1..d6``).
    pose_deg : array_like, shape (6,), optional
        Joint angles (deg); the paper's pose for ``'paper'``, zeros otherwise.
    lengths : dict of str to float, optional
        Link lengths to override (mm), e.g. ``{"d3": 1200.0}``.

    Returns
    -------
    PosedArm
    """
    from calibrator import robots

    lengths = dict(lengths or {})
    key = (model or PAPER).strip()
    # Names are matched without case; a description file's path keeps its own.
    key = PAPER if key.lower() == PAPER else key
    unknown = sorted(set(lengths) - set(length_names(key)))
    if unknown:
        raise CalibrationError(
            f"unknown link length {unknown[0]!r} for {key}; known: {', '.join(length_names(key))}"
        )
    if key == PAPER:
        table = PAPER_CRAIG.copy()
        for name, value in lengths.items():
            i = int(name[1:])
            if name[0] == "a":
                table[i, 1] = value
            else:
                table[i - 1, 2] = value
        table[:, 0] *= _DEG
        pose = PAPER_POSE_DEG if pose_deg is None else np.asarray(pose_deg, dtype=float)
        return craig_arm(table, pose * _DEG, name=misalignment_paper.TITLE)
    described = robots.get(key)
    mdh = described.mdh.copy()
    for name, value in lengths.items():
        mdh[int(name[1:]) - 1, kinematics.A if name[0] == "a" else kinematics.D] = value
    pose = np.zeros(6) if pose_deg is None else np.asarray(pose_deg, dtype=float)
    return mdh_arm(mdh, pose * _DEG, name=described.name)
