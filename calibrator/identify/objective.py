"""The IPSO paper's objective (7), evaluated for a whole swarm at once.

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

How a call is made fast (the identifier makes thousands): at 20 particles
and 26 poses each numpy call costs microseconds of dispatch, as much as its
arithmetic, so an evaluation is a fixed sequence of about 23 calls over all
particles, poses and joints at once, into arrays allocated once per swarm
size (:class:`_Buffers`):

1. deltas -> ``a, d, theta, alpha, beta`` of all joints (one product), their
   cosines and sines and the products of those (four elementwise calls);
2. every link ``Rz(theta) Tz(d) Tx(a) Rx(alpha) Ry(beta)`` of every particle
   from those features in one product with a constant 0/+-1 matrix, link 6
   times the tool frame;
3. the chain, rows before poses: per joint, ``Rz(q_i)`` as a complex phase
   on columns 0 and 1 (it depends on the pose only) and one batched product
   with the links. With the base frame fixed, ``Rz(q1)`` and the base frame
   go to the measurements instead, so the chain starts at link 1, the same
   for every pose; with it free, it starts at each particle's base frame.
   Free base and tool frames are made from their deltas the same way as the
   links (cosines, sines, their products, one product with a constant
   matrix), not with :meth:`ParameterSpace.unpack`, which costs more than
   the whole chain;
4. the measured points are taken off column 3 at the start and the last row
   of every link is ``0 0 0 1``, so the chain ends at the position errors:
   the objective is then one dot product of them and one with the measured
   rotations.
"""

from typing import TYPE_CHECKING

import numpy as np

from calibrator.model import kinematics
from calibrator.model.parameters import JOINT_TERM_START, N_MDH, TOOL_START
from calibrator.model.rotations import rotations_xyz

if TYPE_CHECKING:
    from calibrator.model.measurement import Observations
    from calibrator.model.parameters import ParameterSpace


class SwarmObjective:
    """``f(X)`` for a swarm of parameter deltas, shape (P, D) -> (P,).

    Everything that depends only on the poses or on the fixed parameters is
    computed once here, so a call costs one batched forward kinematics and a
    few reductions: the identifier calls it thousands of times.

    Made by :meth:`calibrator.identify.problem.Problem.swarm_objective`.

    Parameters
    ----------
    space : calibrator.model.parameters.ParameterSpace
        The free set, over D parameters.
    obs : calibrator.model.measurement.Observations
        The fitting poses (N of them).
    k : float
        Orientation weight (mm^2/rad^2), as the problem resolved it.
    loss : {'lsq', 'minimax'}
        Sum over the poses, or the worst pose.

    Notes
    -----
    Calls share work arrays (one set per swarm size): the values returned
    are fresh arrays, but one objective must not be called from two threads
    at once.
    """

    def __init__(
        self, space: "ParameterSpace", obs: "Observations", k: float, loss: str = "lsq"
    ) -> None:
        if loss not in ("lsq", "minimax"):
            raise ValueError(f"swarm loss must be 'lsq' or 'minimax', got {loss!r}")
        self.minimax = loss == "minimax"
        self.space = space
        self.n_poses = len(obs.q)
        self.k = k
        index = space.index
        mdh_cols = np.flatnonzero(index < N_MDH)
        self.base_free = bool(np.any((index >= N_MDH) & (index < TOOL_START)))
        # (Joint terms, if free, do not enter the swarm's objective.)
        self.tool_free = bool(np.any((index >= TOOL_START) & (index < JOINT_TERM_START)))
        self._tables(space, index[mdh_cols], mdh_cols, obs.q)
        if self.base_free or self.tool_free:
            self._frame_tables(space, index)
        # What the chain's end is compared with: the measured points and
        # rotations. With the base frame free the chain starts from each
        # particle's base2tracker, turned by q1, and ends in the tracker
        # frame. With it fixed, the measurements are brought into the base
        # frame and then into the frame after Rz(q1) of their pose:
        # |B Rz p - m| = |p - Rz^T B^-1 m| and trace(M^T B Rz X) =
        # trace((Rz^T B^T M)^T X); the chain then starts at link 1, the same
        # for every pose, turned by q2 (see _Buffers.chain).
        points = obs.points
        rotations = obs.rotations if self.k else None
        if not self.base_free:
            base0 = space.base0
            points = (points - base0[:3, 3]) @ base0[:3, :3]
            q1 = np.zeros((len(obs.q), 3))
            q1[:, 2] = obs.q[:, 0]
            turn_back = np.swapaxes(rotations_xyz(q1), -1, -2)  # Rz(q1)^T per pose
            points = np.einsum("nij,nj->ni", turn_back, points)
            if rotations is not None:
                rotations = turn_back @ (base0[:3, :3].T @ rotations)
        # The chain starts from rows whose column 3 is less the measured
        # point: column 3 only ever gains multiples of itself times 1 (the
        # last row of every link is 0 0 0 1), so the chain ends at the error
        # p - m. As complex numbers (columns 2 + 3j) per row and pose.
        self.start_offset = 1j * np.ascontiguousarray(points.T)  # (3, N)
        if rotations is not None:
            # -k trace(R_meas^T R_model) as a dot product with the chain's
            # rows (P, 3, N, 4); column 3 (the error) has weight 0.
            weights = np.zeros((3, self.n_poses, 4))
            weights[..., :3] = np.asarray(rotations).transpose(1, 0, 2)
            self.neg_k_meas = -self.k * weights  # (3, N, 4)
            self.neg_k_meas_flat = self.neg_k_meas.ravel()
        self._buffers: dict[int, _Buffers] = {}

    def _tables(self, space, mdh_index, mdh_cols, q):
        """Constant tables: deltas to link features, features to links, the joints' turns."""
        # x (P, D) -> a, d, theta, alpha, beta of the 6 joints (features
        # _A.._BETA of _Buffers), as one product plus the nominal values:
        # exact, each entry is one delta times 1 plus zeros.
        row_of_column = {kinematics.A: 0, kinematics.D: 1, kinematics.THETA: 2}
        row_of_column.update({kinematics.ALPHA: 3, kinematics.BETA: 4})
        self.to_features = np.zeros((5 * 6, space.size))
        self.feature_bias = np.zeros((5 * 6, 1))
        for col, row in row_of_column.items():
            self.feature_bias[row * 6 : row * 6 + 6, 0] = space.nominal_mdh[:, col]
        for k, flat in zip(mdh_cols, mdh_index, strict=True):
            joint, col = divmod(int(flat), 5)
            self.to_features[row_of_column[col] * 6 + joint, k] = 1.0
        self.to_links = _FEATURES_TO_LINK
        # Link 6 times the tool frame, so that the chain ends at the tool:
        # with the tool fixed, straight from the features.
        with_tool = np.einsum("frk,kc->frc", _FEATURES_TO_LINK.reshape(-1, 4, 4), space.tool0)
        self.to_last_link = with_tool.reshape(-1, 16)
        # Rz(q_i) as phases on columns 0 and 1 (see kinematics.chain_parts), (6, N).
        self.pose_phases = np.ascontiguousarray(kinematics.joint_phases(np.asarray(q, float)).T)

    def _frame_tables(self, space, index):
        """Tables for the free frames: deltas to their features, features to the frames.

        ``base2tracker = base0 . [Rxyz(r) | t]`` and ``flange2tool =
        [R_tool0 Rxyz(r) | t_tool0 + t]`` (as :meth:`ParameterSpace.unpack`)
        are linear in the 27 products ``a_i b_j c_k`` of ``a = (1, cos rx,
        sin rx)``, ``b``, ``c`` likewise for ry and rz, the translation
        deltas ``t`` and 1.
        """
        # x (P, D) -> (tx, ty, tz, rx, ry, rz) deltas of each frame, (2, 6, D).
        self.to_frames = np.zeros((2, 6, space.size))
        for frame, start in enumerate((N_MDH, TOOL_START)):
            for k, i in enumerate(index):
                if start <= i < start + 6:
                    self.to_frames[frame, i - start, k] = 1.0
        # Rxyz entries from the products, (27, 3, 3): r00 = cy cz, ...
        rot = np.zeros((27, 3, 3))
        terms = {
            (0, 0): [((0, 1, 1), 1)],
            (0, 1): [((0, 1, 2), -1)],
            (0, 2): [((0, 2, 0), 1)],
            (1, 0): [((1, 0, 2), 1), ((2, 2, 1), 1)],
            (1, 1): [((1, 0, 1), 1), ((2, 2, 2), -1)],
            (1, 2): [((2, 1, 0), -1)],
            (2, 0): [((2, 0, 2), 1), ((1, 2, 1), -1)],
            (2, 1): [((2, 0, 1), 1), ((1, 2, 2), 1)],
            (2, 2): [((1, 1, 0), 1)],
        }
        for (row, col), entry in terms.items():
            for (i, j, k), sign in entry:
                rot[9 * i + 3 * j + k, row, col] = sign
        # (2, 34, 12): products, t, angles (weight 0), 1 -> top rows of the frame.
        self.frame_maps = np.zeros((2, _FRAME_ONE + 1, 3, 4))
        for frame, (turn, shift, rotate_t) in enumerate(
            (
                (space.base0[:3, :3], space.base0[:3, 3], space.base0[:3, :3]),
                (space.tool0[:3, :3], space.tool0[:3, 3], np.eye(3)),
            )
        ):
            self.frame_maps[frame, :27, :, :3] = np.einsum("rm,fmc->frc", turn, rot)
            self.frame_maps[frame, 27:30, :, 3] = rotate_t.T  # t_m -> row r: rotate_t[r, m]
            self.frame_maps[frame, _FRAME_ONE, :, 3] = shift
        self.frame_maps = self.frame_maps.reshape(2, _FRAME_ONE + 1, 12)

    def __call__(self, x):
        x = np.asarray(x, dtype=float)
        n_sets = len(x)
        buffers = self._buffers.get(n_sets)
        if buffers is None:
            buffers = self._buffers[n_sets] = _Buffers(self, n_sets)
        t = buffers.chain(x, self)  # (P, 3, N, 4)
        # t: the tool pose, column 3 less the measured point (the error).
        if self.minimax:
            error = buffers.errors.reshape(n_sets, 3, self.n_poses)
            per_pose = np.einsum("prn,prn->pn", error, error)
            if self.k:
                per_pose += np.einsum("prnc,rnc->pn", t, self.neg_k_meas)
                per_pose += 3.0 * self.k
            return per_pose.max(axis=1)
        f = _dot(buffers.errors)
        if self.k:
            f += buffers.flat @ self.neg_k_meas_flat
            f += 3.0 * self.k * self.n_poses
        return f


#: Rows of _Buffers.frame_features: 27 products, the translation (27-29),
#: the angles (30-32), 1 (33), then (1, cos, sin) of rx, ry, rz (34-42).
_FRAME_ANGLES, _FRAME_ONE, _FRAME_TRIG = 30, 33, 34


def _dot(d):
    """Sum of squares of each row of ``d`` (P, M) -> (P,): one call."""
    if hasattr(np, "vecdot"):  # numpy >= 2.0: a ufunc, half the time of einsum here
        return np.vecdot(d, d)
    return np.einsum("pj,pj->p", d, d)


# Features of one link: rows of _Buffers.features, one column per joint and
# particle. Rows 13-15 are the angles whose cosines and sines fill rows 0-5.
_CT, _CA, _CB, _ST, _SA, _SB, _CACB, _CASB, _SACB, _SASB, _A, _D = range(12)
_THETA, _ALPHA, _BETA, _ONE = 12, 13, 14, 15
# The features that cos(theta) and sin(theta) multiply (Rz(theta) mixes rows
# 0 and 1 of the link): ca, cb, sb, sa cb, sa sb, a and the four between them.
_TURNED = slice(_CA, _A + 1)
_N_TURNED = _A + 1 - _CA
_N_INPUTS = 16 + 2 * _N_TURNED


def _features_to_link() -> np.ndarray:
    """0/+-1 matrix (36, 16): link features to ``Rz(theta) Tz(d) Tx(a) Rx(alpha) Ry(beta)``.

    The 36 inputs are the 16 features, then cos(theta) times features
    ``_TURNED``, then sin(theta) times them. Each entry of the flattened 4x4 link is one input
    or the sum of two: ``Rz(theta)`` times :func:`kinematics.link_constants`
    written out.
    """
    plain, cos_t, sin_t = 0, 16 - _CA, 16 + _N_TURNED - _CA
    terms = {
        (0, 0): [(cos_t + _CB, 1), (sin_t + _SASB, -1)],
        (0, 1): [(sin_t + _CA, -1)],
        (0, 2): [(cos_t + _SB, 1), (sin_t + _SACB, 1)],
        (0, 3): [(cos_t + _A, 1)],
        (1, 0): [(sin_t + _CB, 1), (cos_t + _SASB, 1)],
        (1, 1): [(cos_t + _CA, 1)],
        (1, 2): [(sin_t + _SB, 1), (cos_t + _SACB, -1)],
        (1, 3): [(sin_t + _A, 1)],
        (2, 0): [(plain + _CASB, -1)],
        (2, 1): [(plain + _SA, 1)],
        (2, 2): [(plain + _CACB, 1)],
        (2, 3): [(plain + _D, 1)],
        (3, 3): [(plain + _ONE, 1)],
    }
    out = np.zeros((_N_INPUTS, 16))
    for (row, col), entry in terms.items():
        for feature, sign in entry:
            out[feature, 4 * row + col] = sign
    return out


_FEATURES_TO_LINK = _features_to_link()


class _Buffers:
    """Work arrays of one swarm size and the forward kinematics written into them.

    The link features keep particles innermost, (feature, joint, P), so that
    their elementwise steps run over long contiguous rows; the chain keeps
    rows before poses, (P, 3, N, 4), so that a joint's turn broadcasts one
    phase per pose along contiguous rows.
    """

    def __init__(self, objective: SwarmObjective, n_sets: int) -> None:
        n = objective.n_poses
        # (36, 6, P): the 16 link features, then cos(theta) and sin(theta)
        # times those that Rz(theta) mixes.
        self.blocks = np.zeros((_N_INPUTS, 6, n_sets))
        features = self.blocks[:16]
        features[_ONE] = 1.0
        self.features = features
        self.deltas = features[_A:_ONE].reshape(30, n_sets)  # a, d, theta, alpha, beta rows
        self.angles = features[_THETA:_ONE]
        self.cos, self.sin = features[_CT : _CB + 1], features[_ST : _SB + 1]
        self.cos_sin_a = features[_CA : _SA + 1 : 3, np.newaxis]  # (2, 1, 6, P)
        self.cos_sin_b = features[np.newaxis, _CB : _SB + 1 : 3]  # (1, 2, 6, P)
        self.products = features[_CACB : _SASB + 1].reshape(2, 2, 6, n_sets)
        self.cos_sin_t = features[_CT : _ST + 1 : 3, np.newaxis]  # (2, 1, 6, P)
        self.to_turn = features[_TURNED]
        self.turned = self.blocks[16:].reshape(2, _N_TURNED, 6, n_sets)
        self.inputs = self.blocks.reshape(_N_INPUTS, 6 * n_sets).T  # (6P, 36)
        self.links = np.empty((6 * n_sets, 16))
        # Link 6 is only needed bare when a free tool frame multiplies it.
        used = 6 * n_sets if objective.tool_free else 5 * n_sets
        self.link_inputs, self.link_outputs = self.inputs[:used], self.links[:used]
        for view in (self.deltas, self.products, self.turned):
            assert np.shares_memory(view, self.blocks)  # written in place, never a copy
        link = list(self.links.reshape(6, n_sets, 4, 4))
        self.last_inputs = self.inputs[5 * n_sets :]  # (P, 36): joint 6
        self.last_link = link[5] = np.empty((n_sets, 4, 4))  # with the tool frame
        # The free frames' features (2 frames, 43 rows, P) and the frames
        # (2, P, 4, 4): base2tracker, then flange2tool.
        self.frame_features = np.zeros((2, _FRAME_TRIG + 9, n_sets))
        self.frame_features[:, _FRAME_ONE] = 1.0
        self.frame_features[:, _FRAME_TRIG::3] = 1.0
        self.frame_deltas = self.frame_features[:, 27:_FRAME_ONE]  # (2, 6, P)
        self.frame_angles = self.frame_features[:, _FRAME_ANGLES:_FRAME_ONE]
        trig = self.frame_features[:, _FRAME_TRIG:]
        self.frame_cos, self.frame_sin = trig[:, 1::3], trig[:, 2::3]
        self.frame_ab = (trig[:, 0:3, np.newaxis], trig[:, np.newaxis, 3:6])  # (2, 3, 3, P)
        self.frame_pairs = np.empty((2, 3, 3, n_sets))
        self.frame_c = trig[:, np.newaxis, np.newaxis, 6:9]
        self.frame_products = self.frame_features[:, :27].reshape(2, 3, 3, 3, n_sets)
        self.frame_inputs = self.frame_features[:, : _FRAME_ONE + 1].transpose(0, 2, 1)
        self.frames = np.zeros((2, n_sets, 16))
        self.frames[..., 15] = 1.0
        self.frame_rows = self.frames[..., :12]
        assert np.shares_memory(self.frame_products, self.frame_features)
        self.base_free, self.tool_free = objective.base_free, objective.tool_free
        self.base, self.tool = self.frames.reshape(2, n_sets, 4, 4)
        # The chain's first rows: each particle's base2tracker, or link 1
        # when the base is fixed (Rz(q1) went to the measurements).
        first = self.base if self.base_free else link[0]
        first_joint = 0 if self.base_free else 1
        # Two chain buffers in turn. The start turns the first rows by the
        # first joint's phase and takes the measured points off column 3:
        # columns (0, 1) and (2, 3) as two complex numbers.
        pair = np.empty((2, n_sets, 3, n, 4))
        top = first[:, :3].view(np.complex128)[..., np.newaxis]  # (P, 3, 2, 1)
        turned = pair[0].view(np.complex128)  # (P, 3, N, 2)
        self.start = (
            top[..., 0, :],
            objective.pose_phases[first_joint],
            turned[..., 0],
            top[..., 1, :],
            turned[..., 1],
        )
        self.steps = []
        for step, joint in enumerate(range(first_joint, 6)):
            src, dst = pair[step % 2], pair[(step + 1) % 2]
            self.steps.append(
                (
                    # Rz(q) of this joint, then its link; the start has
                    # already turned the first rows by the first joint's q.
                    src.view(np.complex128)[..., 0] if step else None,
                    objective.pose_phases[joint],
                    src.reshape(n_sets, 3 * n, 4),
                    link[joint],
                    dst.reshape(n_sets, 3 * n, 4),
                )
            )
        self.last = dst
        self.flat = self.last.reshape(n_sets, 12 * n)
        self.errors = self.last.reshape(n_sets, 3 * n, 4)[..., 3]  # (P, 3N), a view

    def chain(self, x: np.ndarray, objective: SwarmObjective) -> np.ndarray:
        """The tool pose of the swarm ``x`` (P, D) less the measured points, (P, 3, N, 4).

        Rows before poses (mm); column 3 is the position error, in the frame
        the objective compares in. The result lives in this buffer until the
        next call.
        """
        if self.base_free or self.tool_free:
            np.matmul(objective.to_frames, x.T, out=self.frame_deltas)
            np.cos(self.frame_angles, out=self.frame_cos)
            np.sin(self.frame_angles, out=self.frame_sin)
            np.multiply(*self.frame_ab, out=self.frame_pairs)
            np.multiply(self.frame_pairs[..., np.newaxis, :], self.frame_c, out=self.frame_products)
            np.matmul(self.frame_inputs, objective.frame_maps, out=self.frame_rows)
        np.matmul(objective.to_features, x.T, out=self.deltas)
        self.deltas += objective.feature_bias
        np.cos(self.angles, out=self.cos)
        np.sin(self.angles, out=self.sin)
        np.multiply(self.cos_sin_a, self.cos_sin_b, out=self.products)
        np.multiply(self.cos_sin_t, self.to_turn, out=self.turned)
        # Every link of every particle in one product.
        np.matmul(self.link_inputs, objective.to_links, out=self.link_outputs)
        if self.tool_free:
            np.matmul(self.links[5 * len(x) :].reshape(-1, 4, 4), self.tool, out=self.last_link)
        else:
            np.matmul(self.last_inputs, objective.to_last_link, out=self.last_link.reshape(-1, 16))
        xy, phase, turned_xy, zw, offset_zw = self.start
        np.multiply(xy, phase, out=turned_xy)
        np.subtract(zw, objective.start_offset, out=offset_zw)
        for turn, phase, src, link, dst in self.steps:
            if turn is not None:
                turn *= phase  # t @ Rz(q_i): columns 0 and 1 as one complex number
            np.matmul(src, link, out=dst)
        return self.last
