"""Which poses to measure: observability of the parameters and D-optimal selection.

Selection by **D-optimality**: greedily add the candidate that most increases
``log det(J^T J)`` of the identification Jacobian, i.e. the observability
index O1 of Borm and Menq (1991), the product of the singular values; Sun and
Hollerbach (2008, "Observability index selection for robot calibration",
ICRA) compare it with the other indices and show greedy selection of this
kind. Angle columns of the Jacobian are divided by :data:`ANGLE_SCALE_MM` so
millimetres and radians weigh alike (otherwise the criterion depends on the
units chosen).

Joint angles rad, lengths mm, positions in the robot base frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from calibrator.model import measurement, parameters
from calibrator.planning.plan import PlanError

#: Scale of angle columns (mm per rad) before computing the criterion: about an arm's reach.
ANGLE_SCALE_MM = 1000.0


@dataclass(frozen=True)
class Observability:
    """The identification Jacobian's pose blocks, for choosing and scoring poses.

    Attributes
    ----------
    names : tuple of str
        Parameters the blocks' columns belong to (those the model can identify).
    blocks : ndarray, shape (N, 3, P)
        Position rows of each pose (mm per mm, or per mm-equivalent: angle
        columns divided by :data:`ANGLE_SCALE_MM`).
    """

    names: tuple
    blocks: np.ndarray


def observability(
    mdh: np.ndarray,
    q: np.ndarray,
    flange2tool: ArrayLike | None = None,
    frame: str = "tracker",
    tool_known: bool = False,
    names: tuple | None = None,
) -> Observability:
    """Scaled identification Jacobian of each pose (position rows), nominal arm.

    The free set is the one ``identify`` starts from
    (:func:`calibrator.identify.freeset.decide` without a session: Hayati's
    structural candidates less the model's own redundancies); which of them
    the measured poses then pin down is decided at identification. ``names``
    (of :data:`calibrator.model.parameters.ALL_NAMES`) replaces it, e.g. with what
    drifts (``calibrator check``'s joint zeros, base and tool).
    """
    from calibrator.identify import freeset

    q = np.atleast_2d(np.asarray(q, dtype=float))
    tool = np.eye(4) if flange2tool is None else np.asarray(flange2tool, dtype=float)
    if names is None:
        free = freeset.decide(mdh, frame, tool_known, False, tool0=tool)
        kept, space = free.names, free.space
    else:
        space = parameters.ParameterSpace(np.asarray(mdh, float), tool0=tool, free=tuple(names))
        kept = space.free
    pose = measurement.predict(space, np.zeros(space.size), q)
    obs = measurement.Observations(q, pose[:, :3, 3])
    jac = measurement.jacobian(space, np.zeros(space.size), obs)
    scale = np.array([1.0 / ANGLE_SCALE_MM if parameters.unit(n) == "rad" else 1.0 for n in kept])
    blocks = (jac * scale).reshape(len(q), 3, len(kept))
    return Observability(tuple(kept), blocks)


def log_det(blocks: np.ndarray) -> float:
    """D-optimality criterion: ``log det(J^T J)`` of stacked blocks (N, 3, P); -inf if singular."""
    jac = np.asarray(blocks).reshape(-1, np.shape(blocks)[-1])
    sign, value = np.linalg.slogdet(jac.T @ jac)
    return float(value) if sign > 0 else -np.inf


def min_singular(blocks: np.ndarray) -> float:
    """Smallest singular value of the stacked blocks (N, 3, P) (observability index O3)."""
    jac = np.asarray(blocks).reshape(-1, np.shape(blocks)[-1])
    return float(np.linalg.svd(jac, compute_uv=False)[-1])


def select_d_optimal(blocks: np.ndarray, n: int) -> np.ndarray:
    """Greedy D-optimal choice of ``n`` poses from blocks (C, 3, P); indices in pick order.

    Each step adds the candidate with the largest ``log det(I + J_c M^-1 J_c^T)``
    (the increase of ``log det M`` by the matrix determinant lemma), with
    ``M`` the information matrix of the poses picked so far plus a small ridge.
    """
    blocks = np.asarray(blocks, dtype=float)
    c, _, p = blocks.shape
    if n > c:
        raise PlanError(f"{n} poses asked, only {c} candidates satisfy the cell's constraints")
    ridge = 1e-9 * np.einsum("ckp,ckp->", blocks, blocks) / c
    info = ridge * np.eye(p)
    chosen = np.zeros(c, dtype=bool)
    picks = []
    for _ in range(n):
        solved = np.linalg.solve(info, blocks.reshape(-1, p).T).T.reshape(c, 3, p)
        gain_mat = np.eye(3) + np.einsum("ckp,cjp->ckj", blocks, solved)
        gain = np.linalg.slogdet(gain_mat)[1]
        gain[chosen] = -np.inf
        best = int(np.argmax(gain))
        chosen[best] = True
        picks.append(best)
        info = info + blocks[best].T @ blocks[best]
    return np.array(picks)


def leave_one_out(blocks: np.ndarray) -> np.ndarray:
    """What leaving each pose out costs the D-optimality criterion, shape (N,).

    ``log det M - log det(M - J_i^T J_i)`` for blocks (N, 3, P) with
    ``M = J^T J`` (by the matrix determinant lemma: ``-log det(I - J_i M^-1
    J_i^T)``); ``inf`` where leaving pose i out makes ``M`` singular.
    """
    blocks = np.asarray(blocks, dtype=float)
    n, _, p = blocks.shape
    info = np.einsum("nkp,nkq->pq", blocks, blocks)
    solved = np.linalg.lstsq(info, blocks.reshape(-1, p).T, rcond=None)[0].T.reshape(n, 3, p)
    sign, value = np.linalg.slogdet(np.eye(3) - np.einsum("nkp,njp->nkj", blocks, solved))
    return np.where(sign > 0, -value, np.inf)


def min_poses(mdh: np.ndarray, frame: str = "tracker", tool_known: bool = False) -> int:
    """Fewest poses whose position rows can determine the identifiable parameters."""
    from calibrator.identify import freeset

    return -(-len(freeset.decide(mdh, frame, tool_known, False).names) // 3)
