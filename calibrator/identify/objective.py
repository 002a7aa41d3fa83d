"""The seed's objective (7), evaluated for a whole swarm at once.

    f = sum_j [ k * |delta_j|^2 + |dp_j|^2 ]

``dp_j`` is the position error of pose j (mm) and ``delta_j`` its orientation
error (rad). For the swarm the orientation term uses the chordal form
``2 (1 - cos theta_j) = 3 - trace(R_meas^T R_model)``, which equals
``theta_j^2`` to fourth order (errors here are milliradians) and costs one
product instead of a matrix logarithm per pose and particle.
"""

import numpy as np

from calibrator import kinematics
from calibrator.measurement import uses_orientation
from calibrator.parameters import N_BASE, N_MDH


class SwarmObjective:
    """``f(X)`` for a swarm of parameter deltas, shape (P, D) -> (P,).

    Everything that depends only on the poses or on the fixed parameters is
    computed once here, so a call costs one batched forward kinematics and a
    few reductions: the identifier calls it thousands of times.

    Parameters
    ----------
    space : calibrator.parameters.ParameterSpace
    obs : calibrator.measurement.Observations
        The fitting poses.
    k : float
        Orientation weight (mm^2/rad^2); ignored without orientation data.
    """

    def __init__(self, space, obs, k=0.0):
        self.space = space
        self.points = obs.points
        self.q_phase = kinematics.joint_phases(obs.q)
        self.k = float(k) if uses_orientation(obs, k) else 0.0
        index = space.index
        self.mdh_cols = np.flatnonzero(index < N_MDH)
        self.mdh_index = index[self.mdh_cols]
        self.base_free = bool(np.any((index >= N_MDH) & (index < N_MDH + N_BASE)))
        self.tool_free = bool(np.any(index >= N_MDH + N_BASE))
        self.base_fixed = None if self.base_free else space.base0
        if self.base_fixed is not None and np.array_equal(self.base_fixed, np.eye(4)):
            self.base_fixed = None  # the base frame: nothing to apply
        self.tool_h = space.tool0[:, 3]  # homogeneous tool point in the flange frame
        self.nominal_flat = space.nominal_mdh.ravel().copy()
        if self.k:
            # trace(R_meas^T B R_flange R_tool) = sum(R_flange * (B^T R_meas R_tool^T));
            # padded to 3x4 with a zero column so it lines up with base2flange.
            target = obs.rotations @ space.tool0[:3, :3].T
            if not self.base_free:
                target = space.base0[:3, :3].T @ target
            self.meas_tool = np.zeros((len(obs.q), 3, 4))
            self.meas_tool[..., :3] = target

    def __call__(self, x):
        x = np.asarray(x, dtype=float)
        mdh = np.empty((len(x), 30))
        mdh[:] = self.nominal_flat
        mdh[:, self.mdh_index] += x[:, self.mdh_cols]
        mdh = mdh.reshape(len(x), 6, 5)
        if self.base_free or self.tool_free:
            _, base2tracker, flange2tool = self.space.unpack(x)
        top = kinematics.chain_parts(
            kinematics.link_constants(mdh),
            kinematics.joint_phases(mdh[..., kinematics.THETA]),
            self.q_phase,
        )  # (P, N, 3, 4) base2flange
        n_sets, n_poses = top.shape[:2]
        if self.tool_free:
            p = np.matmul(top.reshape(n_sets, n_poses * 3, 4), flange2tool[:, :, 3:4])
        else:
            p = top.reshape(-1, 4) @ self.tool_h
        p = p.reshape(n_sets, n_poses, 3)  # tool point, base frame
        if self.base_free:
            p = np.matmul(p, np.swapaxes(base2tracker[:, :3, :3], -1, -2))
            p += base2tracker[:, np.newaxis, :3, 3]
        elif self.base_fixed is not None:
            p = p @ self.base_fixed[:3, :3].T + self.base_fixed[:3, 3]
        d = (p - self.points).reshape(n_sets, -1)
        f = np.einsum("pj,pj->p", d, d)
        if self.k:
            if self.base_free:
                # B^T applied to the measured orientations, per particle.
                b_t = np.swapaxes(base2tracker[:, :3, :3], -1, -2)
                target = np.matmul(b_t[:, np.newaxis], self.meas_tool)
                trace = np.einsum("pj,pj->p", top.reshape(n_sets, -1), target.reshape(n_sets, -1))
            else:
                trace = top.reshape(n_sets, -1) @ self.meas_tool.ravel()
            f += self.k * (3.0 * n_poses - trace)
        return f
