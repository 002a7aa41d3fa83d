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

Both are built by the model's one forward kinematics: a Craig table is first
converted exactly to MDH (:func:`calibrator.model.conventions.craig_to_mdh`),
and ``L_i`` is :func:`calibrator.model.kinematics.joint_origins` of the table
turned to the pose.

All transforms are stored as their top three rows, shape ``(..., 3, 4)`` (mm).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from calibrator.errors import CalibrationError
from calibrator.model import conventions, kinematics
from calibrator.robots import misalignment_paper

_DEG = np.pi / 180.0

#: The misalignment paper's arm (its Table 2), Craig modified DH:
#: rows ``[alpha_{i-1} (deg), a_{i-1} (mm), d_i (mm)]``.
PAPER_CRAIG = misalignment_paper.CRAIG_TABLE
#: The paper's pose, joint angles theta_1..6 (deg).
PAPER_POSE_DEG = misalignment_paper.POSE_DEG


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
    q = _check_pose(pose_rad)
    try:
        base2frame0, mdh = conventions.craig_to_mdh(table)
    except ValueError as exc:
        raise CalibrationError(str(exc)) from None
    return _posed(mdh, q, base2frame0, name)


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
    return _posed(mdh, q, None, name)


def _posed(mdh: np.ndarray, q: np.ndarray, base2frame0: np.ndarray | None, name: str) -> PosedArm:
    """The :class:`PosedArm` of an MDH table at pose ``q``, after an optional base offset."""
    # Turned to the pose, the table's joint origins are the links: O_i Rz(q_i)
    # is O_i with theta_i + q_i.
    posed = mdh.copy()
    posed[:, kinematics.THETA] += q
    origins, trailing = kinematics.joint_origins(posed)
    if base2frame0 is not None:
        origins[0] = base2frame0 @ origins[0]
    return PosedArm(links=origins[:, :3].copy(), tail=trailing[:3].copy(), name=name)


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
