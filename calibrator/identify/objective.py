"""The seed's objective (7), evaluated for a whole swarm at once.

    f = sum_j [ k * |delta_j|^2 + |dp_j|^2 ]

``dp_j`` is the position error of pose j (mm) and ``delta_j`` its orientation
error (rad). For the swarm the orientation term uses the chordal form
``2 (1 - cos theta_j) = 3 - trace(R_meas^T R_model)``, which equals
``theta_j^2`` to fourth order (errors here are milliradians) and costs one
product instead of a matrix logarithm per pose and particle.

With ``loss="minimax"`` the value is instead the worst pose's
``k * |delta_j|^2 + |dp_j|^2`` (chordal orientation term as above): the
objective of a fit held to its worst pose, which least squares cannot
minimise and the swarm can.
"""

from typing import TYPE_CHECKING

import numpy as np

from calibrator import kinematics
from calibrator.parameters import N_MDH, TOOL_ROTATION_START, TOOL_START

if TYPE_CHECKING:
    from calibrator.identify.problem import Problem


class SwarmObjective:
    """``f(X)`` for a swarm of parameter deltas, shape (P, D) -> (P,).

    Everything that depends only on the poses or on the fixed parameters is
    computed once here, so a call costs one batched forward kinematics and a
    few reductions: the identifier calls it thousands of times.

    Made by :meth:`calibrator.identify.problem.Problem.swarm_objective`.

    Parameters
    ----------
    problem : calibrator.identify.problem.Problem
        The fitting poses, free set and orientation weight (resolved there).
    loss : {'lsq', 'minimax'}
        Sum over the poses, or the worst pose.
    """

    def __init__(self, problem: "Problem", loss: str = "lsq") -> None:
        if loss not in ("lsq", "minimax"):
            raise ValueError(f"swarm loss must be 'lsq' or 'minimax', got {loss!r}")
        space, obs = problem.space, problem.obs
        self.minimax = loss == "minimax"
        self.space = space
        self.points = obs.points
        self.q_phase = kinematics.joint_phases(obs.q)
        self.k = problem.k
        index = space.index
        self.mdh_cols = np.flatnonzero(index < N_MDH)
        self.mdh_index = index[self.mdh_cols]
        self.base_free = bool(np.any((index >= N_MDH) & (index < TOOL_START)))
        self.tool_free = bool(np.any(index >= TOOL_START))
        self.tool_turn_free = bool(np.any(index >= TOOL_ROTATION_START))
        self.base_fixed = None if self.base_free else space.base0
        if self.base_fixed is not None and np.array_equal(self.base_fixed, np.eye(4)):
            self.base_fixed = None  # the base frame: nothing to apply
        self.tool_h = space.tool0[:, 3]  # homogeneous tool point in the flange frame
        self.nominal_flat = space.nominal_mdh.ravel().copy()
        # Deltas -> flat MDH tables as one product with a 0/1 matrix (D, 30):
        # two numpy calls per evaluation instead of four, and exact (each
        # entry is one delta times 1 plus zeros).
        self.to_mdh = np.zeros((space.size, N_MDH))
        self.to_mdh[self.mdh_cols, self.mdh_index] = 1.0
        if self.k and (self.tool_turn_free or self.minimax):
            self.meas_rot = obs.rotations  # (N, 3, 3), tracker frame
            if not self.base_free:
                self.meas_rot = space.base0[:3, :3].T @ self.meas_rot  # base frame
        elif self.k:
            # trace(R_meas^T B R_flange R_tool) = sum(R_flange * (B^T R_meas R_tool^T));
            # padded to 3x4 with a zero column so it lines up with base2flange.
            target = obs.rotations @ space.tool0[:3, :3].T
            if not self.base_free:
                target = space.base0[:3, :3].T @ target
            self.meas_tool = np.zeros((len(obs.q), 3, 4))
            self.meas_tool[..., :3] = target

    def __call__(self, x):
        x = np.asarray(x, dtype=float)
        mdh = (x @ self.to_mdh + self.nominal_flat).reshape(len(x), 6, 5)
        base2tracker = flange2tool = None
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
        d = p - self.points
        if self.minimax:
            per_pose = np.einsum("pnj,pnj->pn", d, d)
            if self.k:
                per_pose += self.k * (3.0 - self._traces(top, base2tracker, flange2tool))
            return per_pose.max(axis=1)
        d = d.reshape(n_sets, -1)
        f = np.einsum("pj,pj->p", d, d)
        if self.k and self.tool_turn_free:
            # Sum over poses before the per-particle tool rotation:
            # sum_n trace(R_meas^T B R_fl R_tool) = trace((sum_n R_meas^T B R_fl) R_tool).
            model = top[..., :3]
            if self.base_free:
                model = np.matmul(base2tracker[:, np.newaxis, :3, :3], model)
            s = np.einsum("nji,pnjl->pil", self.meas_rot, model)
            f += self.k * (3.0 * n_poses - np.einsum("pil,pli->p", s, flange2tool[:, :3, :3]))
        elif self.k:
            if self.base_free:
                # B^T applied to the measured orientations, per particle.
                b_t = np.swapaxes(base2tracker[:, :3, :3], -1, -2)
                target = np.matmul(b_t[:, np.newaxis], self.meas_tool)
                trace = np.einsum("pj,pj->p", top.reshape(n_sets, -1), target.reshape(n_sets, -1))
            else:
                trace = top.reshape(n_sets, -1) @ self.meas_tool.ravel()
            f += self.k * (3.0 * n_poses - trace)
        return f

    def _traces(self, top, base2tracker, flange2tool):
        """``trace(R_meas^T R_model)`` per particle and pose, shape (P, N)."""
        model = top[..., :3]
        if self.base_free:
            model = np.matmul(base2tracker[:, np.newaxis, :3, :3], model)
        if self.tool_free:
            model = np.matmul(model, flange2tool[:, np.newaxis, :3, :3])
        else:
            model = model @ self.space.tool0[:3, :3]
        return np.einsum("nij,pnij->pn", self.meas_rot, model)
