"""Inverse kinematics and the geometric Jacobian of a tool on the modified-DH chain.

:func:`solve` finds joint angles reaching tool poses by damped Newton
(Levenberg-Marquardt) steps on the geometric Jacobian (:func:`jacobian`), per
target, vectorised over targets: a step is kept only if it lowers the error,
else the damping grows. The error is the position (mm) and the rotation
vector (rad, weighted :data:`ROT_WEIGHT_MM`) in the base frame; a target
converges when the position error is below :data:`TOL_MM` and the rotation
error below :data:`TOL_RAD`, in at most :data:`MAX_ITER` iterations. A result
outside the joint limits is reported (:attr:`Solution.reason`), never clipped.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from calibrator.model import kinematics, rotations

#: Position tolerance of the IK (mm).
TOL_MM = 1e-6
#: Orientation tolerance of the IK (rad).
TOL_RAD = 1e-9
#: Iteration cap of the IK.
MAX_ITER = 50
#: Weight of a rotation error against a position error (mm/rad).
ROT_WEIGHT_MM = 1000.0

#: :attr:`Solution.reason` of a target reached within the limits.
REACHED = "ok"
#: :attr:`Solution.reason` of a target the iterations did not reach.
NOT_REACHED = "not reached"
#: :attr:`Solution.reason` of a target reached only outside the joint limits.
OUTSIDE_LIMITS = "outside joint limits"


@dataclass(frozen=True)
class Solution:
    """IK results for N targets.

    Attributes
    ----------
    q : ndarray, shape (N, 6)
        Joint angles (rad); for failed targets, the last iterate (not clipped).
    converged : ndarray of bool, shape (N,)
    within_limits : ndarray of bool, shape (N,)
    iterations : ndarray of int, shape (N,)
    error_mm, error_rad : ndarray, shape (N,)
        Remaining position and rotation error.
    """

    q: np.ndarray
    converged: np.ndarray
    within_limits: np.ndarray
    iterations: np.ndarray
    error_mm: np.ndarray
    error_rad: np.ndarray

    @property
    def ok(self) -> np.ndarray:
        """Success: targets reached within the joint limits, shape (N,)."""
        return self.converged & self.within_limits

    @property
    def reason(self) -> np.ndarray:
        """Why each target succeeded or failed, shape (N,) of str.

        :data:`REACHED`, :data:`NOT_REACHED` (not converged, whatever the
        limits say of the last iterate) or :data:`OUTSIDE_LIMITS`.
        """
        return np.where(
            ~self.converged, NOT_REACHED, np.where(self.within_limits, REACHED, OUTSIDE_LIMITS)
        )


def _tool_rows(tool, idx):
    """The tool of the targets ``idx``: one (4, 4) for all, or the rows of an (N, 4, 4)."""
    return tool if tool.ndim == 2 else tool[idx]


def jacobian(
    mdh: ArrayLike, q: np.ndarray, flange2tool: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Geometric Jacobian of the tool point and the tool pose at each joint vector.

    Parameters
    ----------
    mdh : array_like, shape (6, 5)
    q : ndarray, shape (N, 6)
        Joint angles (rad).
    flange2tool : ndarray, shape (4, 4) or (N, 4, 4)

    Returns
    -------
    jac : ndarray, shape (N, 6, 6)
        Rows: tool point velocity (mm/rad) then angular velocity (rad/rad),
        both in the base frame; columns: joints 1..6.
    pose : ndarray, shape (N, 4, 4)
        Tool poses in the base frame (mm).
    """
    _, link_frames = kinematics.chain(mdh, q, all_frames=True)
    pose = link_frames[:, 6] @ flange2tool
    axes = link_frames[:, :6, :3, 2]  # joint i+1 turns about z of frame i
    arms = pose[:, None, :3, 3] - link_frames[:, :6, :3, 3]
    jac = np.empty((len(q), 6, 6))
    jac[:, :3] = np.swapaxes(np.cross(axes, arms), 1, 2)
    jac[:, 3:] = np.swapaxes(axes, 1, 2)
    return jac, pose


def _pose_error(target, pose):
    dp = target[:, :3, 3] - pose[:, :3, 3]
    dr = rotations.rotation_error(target[:, :3, :3], pose[:, :3, :3])
    return np.concatenate([dp, dr], axis=1)


def solve(
    mdh: ArrayLike,
    targets: ArrayLike,
    q0: ArrayLike,
    flange2tool: ArrayLike | None = None,
    limits: ArrayLike | None = None,
) -> Solution:
    """Joint angles reaching tool poses, by damped Newton (Levenberg-Marquardt) from ``q0``.

    Parameters
    ----------
    mdh : array_like, shape (6, 5)
    targets : array_like, shape (N, 4, 4)
        Desired tool poses, base frame (mm).
    q0 : array_like, shape (N, 6)
        Start (rad): the nominal solution.
    flange2tool : array_like, shape (4, 4) or (N, 4, 4), optional
        One tool for every target, or one per target (a program's targets
        name their own tools).
    limits : array_like, shape (6, 2), optional
        Joint limits (rad); all within when omitted.

    Returns
    -------
    Solution
    """
    targets = np.asarray(targets, dtype=float)
    q = kinematics.check_joints(q0).copy()
    tool = np.eye(4) if flange2tool is None else np.asarray(flange2tool, dtype=float)
    n = len(q)
    weight = np.array([1.0, 1.0, 1.0, ROT_WEIGHT_MM, ROT_WEIGHT_MM, ROT_WEIGHT_MM])
    iterations = np.zeros(n, dtype=int)
    lam = np.full(n, 1e-3)
    jac, pose = jacobian(mdh, q, tool)
    err = _pose_error(targets, pose)
    active = ~_done(err)
    for _ in range(MAX_ITER):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        j = jac[idx] * weight[:, None]
        e = err[idx] * weight
        jt = np.swapaxes(j, 1, 2)
        jtj = jt @ j
        # Marquardt's scaling: damping proportional to the diagonal.
        damp = lam[idx, None, None] * (np.eye(6) * np.diagonal(jtj, axis1=1, axis2=2)[:, None, :])
        dq = np.linalg.solve(jtj + damp, jt @ e[..., None])[..., 0]
        trial_q = q[idx] + dq
        trial_jac, trial_pose = jacobian(mdh, trial_q, _tool_rows(tool, idx))
        trial_err = _pose_error(targets[idx], trial_pose)
        better = np.sum((trial_err * weight) ** 2, axis=1) < np.sum(e**2, axis=1)
        take = idx[better]
        q[take], jac[take], err[take] = trial_q[better], trial_jac[better], trial_err[better]
        lam[take] = np.maximum(lam[take] / 10.0, 1e-9)
        lam[idx[~better]] *= 10.0
        iterations[idx] += 1
        active[take[_done(err[take])]] = False
        active[idx[lam[idx] > 1e8]] = False  # stuck: no step lowers the error
    e_mm = np.linalg.norm(err[:, :3], axis=1)
    e_rad = np.linalg.norm(err[:, 3:], axis=1)
    converged = _done(err)
    if limits is None:
        within = np.ones(n, dtype=bool)
    else:
        lim = np.asarray(limits, dtype=float)
        within = np.all((q >= lim[:, 0]) & (q <= lim[:, 1]), axis=1)
    return Solution(q, converged, within, iterations, e_mm, e_rad)


def _done(err):
    return (np.linalg.norm(err[:, :3], axis=1) < TOL_MM) & (
        np.linalg.norm(err[:, 3:], axis=1) < TOL_RAD
    )
