"""The measurement model: where the tracker sees the tool, and its Jacobian.

A measured point is ``p = base2tracker . A_1...A_6 . flange2tool[:, 3]``; a
6-DoF probe also gives the orientation ``base2tracker . A_1...A_6 .
flange2tool`` (rotation part). Residuals are model minus measurement:

* position rows, ``p_model - p_measured`` (mm), three per pose;
* orientation rows, ``sqrt(k) * rotvec(R_model R_measured^T)`` (rad), three
  per pose, when the session has orientation and ``k > 0``.

Their sum of squares is the IPSO paper's objective (7).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from calibrator.model import joint_terms, kinematics, rotations
from calibrator.model.parameters import (
    JOINT_TERM_START,
    N_MDH,
    NAMES_WITH_TERMS,
    TOOL_ROTATION_START,
    TOOL_START,
    ParameterSpace,
)


@dataclass(frozen=True)
class Observations:
    """Measured poses.

    Attributes
    ----------
    q : ndarray, shape (N, 6)
        Joint angles read back from the robot (rad).
    points : ndarray, shape (N, 3)
        Tool point in the tracker frame (mm).
    rotations : ndarray, shape (N, 3, 3), or None
        Probe orientation in the tracker frame, for 6-DoF probes.
    torque : ndarray, shape (N, 6), or None
        Gravity torque about each joint (N m), for compliance joint terms.
    """

    q: np.ndarray
    points: np.ndarray
    rotations: np.ndarray | None = None
    torque: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.q)

    @property
    def has_orientation(self) -> bool:
        return self.rotations is not None

    def subset(self, index: np.ndarray) -> Observations:
        """The observations at ``index`` (an integer array or boolean mask)."""
        rot = None if self.rotations is None else self.rotations[index]
        tau = None if self.torque is None else self.torque[index]
        return Observations(self.q[index], self.points[index], rot, tau)


def predict(
    space: ParameterSpace, x: ArrayLike, q: np.ndarray, torque: np.ndarray | None = None
) -> np.ndarray:
    """Tool poses in the tracker frame for deltas ``x``.

    Parameters
    ----------
    space : calibrator.model.parameters.ParameterSpace
    x : array_like, shape (..., space.size)
    q : array_like, shape (N, 6)
        Joint angles (rad).
    torque : array_like, shape (N, 6), optional
        Gravity torques (N m), needed by free compliance terms.

    Returns
    -------
    ndarray, shape (..., N, 4, 4)
        ``base2tracker . base2flange . flange2tool`` (mm).
    """
    mdh, base2tracker, flange2tool = space.unpack(x)
    if space.has_joint_terms:
        # Joint terms: the chain turns through the effective angles.
        q = joint_terms.effective(q, space.joint_terms(np.asarray(x, dtype=float)), torque)
        if q.ndim > 2:  # a batch of parameter sets, each with its own angles
            lead = q.shape[:-2]
            flat = [
                kinematics.forward(m, qq, f, b)
                for m, qq, f, b in zip(
                    mdh.reshape(-1, 6, 5),
                    q.reshape(-1, *q.shape[-2:]),
                    flange2tool.reshape(-1, 4, 4),
                    base2tracker.reshape(-1, 4, 4),
                    strict=True,
                )
            ]
            return np.stack(flat).reshape(lead + flat[0].shape)
    return kinematics.forward(mdh, q, flange2tool, base2tracker)


def uses_orientation(obs: Observations, k: float) -> bool:
    """Whether orientation rows take part: the data has them and ``k > 0``."""
    return obs.has_orientation and k > 0


def residuals(space: ParameterSpace, x: ArrayLike, obs: Observations, k: float = 0.0) -> np.ndarray:
    """Residual vector of one parameter set.

    Parameters
    ----------
    space : calibrator.model.parameters.ParameterSpace
    x : array_like, shape (space.size,)
    obs : Observations
    k : float
        Orientation weight of the IPSO paper's objective (mm^2/rad^2).

    Returns
    -------
    ndarray, shape (3N,) or (6N,)
        Position rows (mm), then weighted orientation rows.
    """
    pose = predict(space, x, obs.q, obs.torque)
    dp = (pose[:, :3, 3] - obs.points).ravel()
    if not uses_orientation(obs, k):
        return dp
    assert obs.rotations is not None  # uses_orientation: the data has them
    rot = rotations.rotation_error(pose[:, :3, :3], obs.rotations).ravel()

    return np.concatenate([dp, np.sqrt(k) * rot])


def errors(
    space: ParameterSpace, x: ArrayLike, obs: Observations
) -> tuple[np.ndarray, np.ndarray | None]:
    """Per-pose errors for reports.

    Returns
    -------
    position : ndarray, shape (N, 3)
        Model minus measured point (mm).
    orientation : ndarray, shape (N, 3) or None
        Rotation vector of model relative to measured orientation (rad).
    """
    pose = predict(space, x, obs.q, obs.torque)
    position = pose[:, :3, 3] - obs.points
    if obs.rotations is None:
        return position, None
    return position, rotations.rotation_error(pose[:, :3, :3], obs.rotations)


def jacobian(
    space: ParameterSpace,
    x: ArrayLike,
    obs: Observations,
    k: float = 0.0,
    names: Sequence[str] | None = None,
) -> np.ndarray:
    """Analytic Jacobian of :func:`residuals` with respect to named parameters.

    Each MDH parameter is an elementary motion about or along an axis of a
    link frame: a turn ``u`` through ``o`` moves the point by ``u x (p - o)``
    and the orientation by ``u``; a slide along ``u`` moves the point by
    ``u``. The base frame's deltas are elementary motions of the same kind.
    The orientation rows use the small-residual derivative of the rotation
    vector (exact where the residual is zero).

    Parameters
    ----------
    space : calibrator.model.parameters.ParameterSpace
    x : array_like, shape (space.size,)
    obs : Observations
    k : float
        Orientation weight.
    names : sequence of str, optional
        Columns to return, from :data:`calibrator.model.parameters.ALL_NAMES`;
        defaults to ``space.free``.

    Returns
    -------
    ndarray, shape (len(residuals), len(names))
    """
    names = space.free if names is None else tuple(names)
    full = space.expand(np.asarray(x, dtype=float))
    mdh, base2tracker, flange2tool = space.unpack(np.asarray(x, dtype=float))
    q_eff = obs.q
    if space.has_joint_terms:
        q_eff = joint_terms.effective(obs.q, full[JOINT_TERM_START:], obs.torque)
    _, link = kinematics.chain(mdh, q_eff, all_frames=True)  # (N, 7, 4, 4)
    n = len(obs.q)
    p = link[:, 6, :3, :3] @ flange2tool[:3, 3] + link[:, 6, :3, 3]  # tool point, base frame

    # Axes of every joint's elementary motions, base frame, shape (N, 6, 3).
    before, after = link[:, :6], link[:, 1:]
    z_prev, o_prev = before[..., :3, 2], before[..., :3, 3]
    o_i, y_i = after[..., :3, 3], after[..., :3, 1]
    beta = mdh[:, kinematics.BETA]
    # x axis of the frame before Ry(beta): R_i Ry(-beta) e_x.
    x_m = np.cos(beta)[:, None] * after[..., :3, 0] + np.sin(beta)[:, None] * after[..., :3, 2]
    rel_prev, rel_i = p[:, None] - o_prev, p[:, None] - o_i
    zero = np.zeros_like(z_prev)
    # Column order within a joint follows kinematics.COLUMNS: a, alpha, theta, d, beta.
    pos = np.stack(
        [x_m, np.cross(x_m, rel_i), np.cross(z_prev, rel_prev), z_prev, np.cross(y_i, rel_i)],
        axis=-1,
    )  # (N, 6, 3, 5)
    rot = np.stack([zero, x_m, z_prev, zero, y_i], axis=-1)
    b_r = base2tracker[:3, :3]
    pos_mdh = np.einsum("ij,nkjc->nikc", b_r, pos).reshape(n, 3, N_MDH)
    rot_mdh = np.einsum("ij,nkjc->nikc", b_r, rot).reshape(n, 3, N_MDH)

    # Base frame: base2tracker = base0 Trans(t) Rx Ry Rz, turns about moving axes.
    b0_r = space.base0[:3, :3]
    angles = full[N_MDH + 3 : TOOL_START]
    rx = rotations.rotations_xyz([angles[0], 0.0, 0.0])
    rxy = rotations.rotations_xyz([angles[0], angles[1], 0.0])
    turn_axes = np.column_stack([b0_r[:, 0], b0_r @ rx[:, 1], b0_r @ rxy[:, 2]])  # (3, 3)
    origin = space.base0[:3, :3] @ full[N_MDH : N_MDH + 3] + space.base0[:3, 3]
    p_tr = p @ b_r.T + base2tracker[:3, 3]
    turns = np.cross(turn_axes.T[None], (p_tr - origin)[:, None]).transpose(0, 2, 1)
    pos_base = np.concatenate([np.broadcast_to(b0_r, (n, 3, 3)), turns], axis=-1)
    rot_base = np.concatenate([np.zeros((n, 3, 3)), np.broadcast_to(turn_axes, (n, 3, 3))], axis=-1)

    # Tool point: a slide along the flange axes.
    pos_tool = b_r @ link[:, 6, :3, :3]
    none = np.zeros((n, 3, 3))  # the tool point does not turn; the tool's turns do not move it
    # Tool rotation R(tool0) Rx Ry Rz: turns about the tool frame's moving
    # axes, which leave the tool point where it is.
    t_angles = full[TOOL_ROTATION_START:JOINT_TERM_START]
    t_rx = rotations.rotations_xyz([t_angles[0], 0.0, 0.0])
    t_rxy = rotations.rotations_xyz([t_angles[0], t_angles[1], 0.0])
    local = space.tool0[:3, :3] @ np.column_stack([[1.0, 0.0, 0.0], t_rx[:, 1], t_rxy[:, 2]])
    rot_tool_turn = b_r @ link[:, 6, :3, :3] @ local  # (N, 3, 3), tracker-frame axes

    # Joint terms: joint j's theta column times d q_eff_j / d term.
    dq = joint_terms.derivatives(obs.q, obs.torque).reshape(n, 4, 6)
    theta_cols = [j * 5 + kinematics.THETA for j in range(6)]
    pos_terms = (pos_mdh[..., theta_cols][:, :, None, :] * dq[:, None]).reshape(n, 3, 24)
    rot_terms = (rot_mdh[..., theta_cols][:, :, None, :] * dq[:, None]).reshape(n, 3, 24)

    pos_all = np.concatenate([pos_mdh, pos_base, pos_tool, none, pos_terms], axis=-1)
    cols = [NAMES_WITH_TERMS.index(name) for name in names]
    jac = pos_all[..., cols].reshape(3 * n, len(cols))
    if uses_orientation(obs, k):
        rot_all = np.concatenate([rot_mdh, rot_base, none, rot_tool_turn, rot_terms], axis=-1)
        jac = np.vstack([jac, np.sqrt(k) * rot_all[..., cols].reshape(3 * n, len(cols))])
    return jac
