"""Where the nominal arm puts each pose in the tracker frame: base and reflector fitted to stops.

The tracker-to-robot registration (the base) and the reflector's position on
the flange (the tool) are both unknown when a run starts: the base entirely,
the tool within :data:`TOOL_BOUND_MM` of the ``--tool`` guess. Given stops
already matched to plan poses, :func:`register` fits both to them (a rigid
Kabsch fit with the guessed tool, then Gauss-Newton on base and tool together)
and says how well the nominal arm then predicts a stop it was not fitted to:
the **leave-one-out misfit** of every matched stop, the distance between the
stop and where the registration fitted to the *other* stops puts its pose.
That is the yardstick a new stop is held to (see :mod:`.associate`).

Units: mm; flange poses in the robot base frame, stops in the tracker frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from calibrator.model import frames
from calibrator.model.rotations import rotvec_to_matrix

#: How far the reflector may be from the ``--tool`` guess, mm. A reflector on a
#: flange adapter is placed by drawing to a few millimetres; 30 mm covers a
#: wrong adapter length or a guess from a sketch, and a fit beyond it is no
#: plausible arm.
TOOL_BOUND_MM = 30.0
#: Fewest matched stops from which the tool is fitted (3n equations, 9 unknowns).
TOOL_FIT_STOPS = 4
#: Most Gauss-Newton steps of the base and tool fit (it takes 3 to 5).
_ITERATIONS = 20
#: The fit has converged when a step moves a point less than this, mm (decisions are
#: at the millimetre; the misfits are then exact to far better than the tracker).
_CONVERGED_MM = 1e-4


@dataclass(frozen=True)
class Registration:
    """A base and tool fitted to matched stops.

    Attributes
    ----------
    base2tracker : numpy.ndarray, shape (4, 4)
        Robot base frame to tracker frame, mm.
    tool_mm : numpy.ndarray, shape (3,)
        Reflector position on the flange, mm.
    misfit_mm : numpy.ndarray, shape (n,)
        Distance of each matched stop from its fitted pose, mm.
    loo_mm : numpy.ndarray, shape (n,)
        Leave-one-out misfit of each matched stop: its distance from where the
        registration fitted without it puts its pose, mm (``inf`` where the
        other stops cannot determine the fit).
    """

    base2tracker: np.ndarray
    tool_mm: np.ndarray
    misfit_mm: np.ndarray
    loo_mm: np.ndarray

    @property
    def rms_mm(self) -> float:
        """RMS of the fitted misfits, mm."""
        return float(np.sqrt(np.mean(self.misfit_mm**2)))

    def loo_rms_mm(self, without: int | None = None) -> float:
        """RMS of the leave-one-out misfits (optionally of all stops but ``without``), mm."""
        loo = self.loo_mm if without is None else np.delete(self.loo_mm, without)
        return float(np.sqrt(np.mean(loo**2))) if loo.size else float("inf")

    def predict(self, flange_poses: ArrayLike) -> np.ndarray:
        """Where the reflector is at each flange pose (shape (M, 4, 4)), tracker frame, (M, 3)."""
        flange = np.asarray(flange_poses, dtype=float)
        points = flange[:, :3, :3] @ self.tool_mm + flange[:, :3, 3]
        return points @ self.base2tracker[:3, :3].T + self.base2tracker[:3, 3]


def register(
    flange_poses: ArrayLike,
    measured_mm: ArrayLike,
    tool_guess_mm: ArrayLike,
    tool_bound_mm: float = TOOL_BOUND_MM,
    start_mm: ArrayLike | None = None,
    leave_one_out: bool = True,
) -> Registration | None:
    """Fit base and tool to stops matched to poses.

    Parameters
    ----------
    flange_poses : array_like, shape (n, 4, 4)
        Nominal flange poses of the matched plan poses, robot base frame, mm.
    measured_mm : array_like, shape (n, 3)
        The stops, tracker frame, mm; n >= 3.
    tool_guess_mm : array_like, shape (3,)
        The reflector guess (``--tool``), mm; kept as is below
        :data:`TOOL_FIT_STOPS` stops.
    tool_bound_mm : float
        Largest distance of the fitted tool from the guess, mm.
    start_mm : array_like, shape (3,), optional
        Where the tool fit starts (a previous fit's tool), mm; default the guess.
    leave_one_out : bool
        False skips the leave-one-out misfits (``loo_mm`` is then all ``inf``).

    Returns
    -------
    Registration or None
        None when the best tool is farther than ``tool_bound_mm`` from the
        guess: these stops are not these poses of a plausible arm.
    """
    flange = np.asarray(flange_poses, dtype=float)
    measured = np.asarray(measured_mm, dtype=float).reshape(-1, 3)
    guess = np.asarray(tool_guess_mm, dtype=float).reshape(3)
    fit_tool = len(measured) >= TOOL_FIT_STOPS
    start = guess if start_mm is None else np.asarray(start_mm, dtype=float).reshape(3)
    tool, base = _fit(flange, measured, start if fit_tool else guess, fit_tool)
    if np.linalg.norm(tool - guess) > tool_bound_mm:
        return None
    rot, shift = base[:3, :3], base[:3, 3]
    local = flange[:, :3, :3] @ tool + flange[:, :3, 3]  # (n, 3) base frame
    residual = local @ rot.T + shift - measured  # (n, 3)
    if leave_one_out:
        loo = _leave_one_out(flange, local, rot, residual, fit_tool)
    else:
        loo = np.full(len(measured), np.inf)
    return Registration(base, tool, np.linalg.norm(residual, axis=1), loo)


def _fit(flange, measured, tool, fit_tool: bool):
    """Base (4, 4) and tool (3,): a Kabsch fit, then Gauss-Newton on base and tool together.

    The alternation of the two (Kabsch with the tool fixed, then the tool) converges
    slowly when the tool is poorly seen; Gauss-Newton on the 9 unknowns takes a few steps.
    """
    rotations, origins = flange[:, :3, :3], flange[:, :3, 3]
    base = frames.fit_rigid(rotations @ tool + origins, measured)
    if not fit_tool:
        return tool, base
    rot, shift = base[:3, :3], base[:3, 3]
    for _ in range(_ITERATIONS):
        local = rotations @ tool + origins
        residual = local @ rot.T + shift - measured
        jac = _jacobian(flange, local, rot, fit_tool=True).reshape(-1, 9)
        # normal equations: 9 unknowns, well conditioned once the tool is seen (4+ stops)
        step = np.linalg.lstsq(jac.T @ jac, -jac.T @ residual.reshape(-1), rcond=None)[0]
        rot = rotvec_to_matrix(step[:3]) @ rot
        shift = shift + step[3:6]
        tool = tool + step[6:]
        # a turn of 1e-9 rad moves a point 3 m away by 3e-6 mm
        if 1e3 * np.linalg.norm(step[:3]) + np.linalg.norm(step[3:]) < _CONVERGED_MM:
            break
    return tool, frames.transform(rot, shift)


def _jacobian(flange, local, rot, fit_tool: bool) -> np.ndarray:
    """Derivatives of each predicted point by the base's turn and shift (and the tool), (n, 3, p).

    The turn ``w`` updates ``R`` to ``exp(w) R`` (the shift apart): it moves
    ``R p + o`` by ``w x R p``.
    """
    n = len(local)
    world = local @ rot.T  # R p_k, (n, 3)
    cross = np.zeros((n, 3, 3))  # -[R p_k]_x : the derivative by a small rotation
    cross[:, 0, 1], cross[:, 0, 2] = world[:, 2], -world[:, 1]
    cross[:, 1, 0], cross[:, 1, 2] = -world[:, 2], world[:, 0]
    cross[:, 2, 0], cross[:, 2, 1] = world[:, 1], -world[:, 0]
    blocks = [cross, np.broadcast_to(np.eye(3), (n, 3, 3))]
    if fit_tool:
        blocks.append(rot @ flange[:, :3, :3])
    return np.concatenate(blocks, axis=2)


def _leave_one_out(flange, local, rot, residual, fit_tool: bool) -> np.ndarray:
    """Leave-one-out misfits (n,), mm, from the fit's leverages (exact for a linear fit).

    The residual of stop k refitted without it is ``(I - H_kk)^-1 r_k``, with
    ``H_kk = J_k (J^T J)^-1 J_k^T`` the 3x3 block of the hat matrix; ``J_k``
    the derivatives of the predicted point by the base's rotation and shift
    and (when fitted) the tool.
    """
    n = len(local)
    jac = _jacobian(flange, local, rot, fit_tool)  # (n, 3, p)
    normal = np.einsum("kip,kiq->pq", jac, jac)
    inverse = np.linalg.pinv(normal)
    hat = np.einsum("kip,pq,kjq->kij", jac, inverse, jac)  # (n, 3, 3)
    rest = np.eye(3) - hat
    loo = np.full(n, np.inf)
    # Where the others leave a direction of the fit undetermined, the stop cannot be checked.
    ok = np.linalg.eigvalsh(0.5 * (rest + rest.transpose(0, 2, 1))).min(axis=1) > 1e-6
    if ok.any():
        loo[ok] = np.linalg.norm(np.linalg.solve(rest[ok], residual[ok][..., None])[..., 0], axis=1)
    return loo
