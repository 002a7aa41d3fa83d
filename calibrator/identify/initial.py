"""Closed-form first guesses of the base frame and the tool frame."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from calibrator.model import frames, kinematics

if TYPE_CHECKING:
    from calibrator.model.measurement import Observations


def tool_point(base2flange: np.ndarray, base2tracker: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Least-squares tool point in the flange frame for a known base frame.

    Parameters
    ----------
    base2flange : ndarray, shape (N, 4, 4)
        Flange poses in the base frame (mm).
    base2tracker : ndarray, shape (4, 4)
    points : ndarray, shape (N, 3)
        Measured points, tracker frame (mm).

    Returns
    -------
    ndarray, shape (3,)
    """
    rot = base2tracker[:3, :3] @ base2flange[:, :3, :3]  # (N, 3, 3)
    rhs = points - (base2flange[:, :3, 3] @ base2tracker[:3, :3].T + base2tracker[:3, 3])
    return np.linalg.lstsq(rot.reshape(-1, 3), rhs.ravel(), rcond=None)[0]


def tool_rotation(
    base2flange: np.ndarray, base2tracker: np.ndarray, rotations: np.ndarray
) -> np.ndarray:
    """Least-squares (chordal) tool rotation in the flange frame.

    Each pose gives one estimate ``(B R_flange)^T R_measured``; the rotation
    nearest to their sum (projected with an SVD) maximises the summed
    ``trace`` agreement, so a probe mounted at any angle is found in one step.

    Parameters
    ----------
    base2flange : ndarray, shape (N, 4, 4)
        Nominal flange poses in the base frame.
    base2tracker : ndarray, shape (4, 4)
    rotations : ndarray, shape (N, 3, 3)
        Measured probe orientations, tracker frame.

    Returns
    -------
    ndarray, shape (3, 3)
    """
    model = base2tracker[:3, :3] @ base2flange[:, :3, :3]
    total = np.einsum("nji,njk->ik", model, rotations)
    u, _, vt = np.linalg.svd(total)
    fix = np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))])
    return u @ fix @ vt


def first_guess(
    nominal_mdh: np.ndarray,
    obs: Observations,
    flange2tool: np.ndarray,
    frame: str,
    tool_known: bool,
    iterations: int = 20,
) -> tuple[np.ndarray, np.ndarray]:
    """``base2tracker`` and ``flange2tool`` to start the identification from.

    In the base frame, ``base2tracker`` is the identity. In the tracker frame
    it is the best-fit rigid transform between the nominal model's tool
    points and the measured points (Kabsch); with an unknown tool point the
    fit alternates with a linear least-squares fit of the tool point. With
    orientation data and an unknown tool, the tool rotation is then
    :func:`tool_rotation` (the session's guess of it is not used).

    Parameters
    ----------
    nominal_mdh : ndarray, shape (6, 5)
    obs : calibrator.model.measurement.Observations
    flange2tool : ndarray, shape (4, 4)
        The session's first guess of the tool.
    frame : {'base', 'tracker'}
    tool_known : bool
    iterations : int
        Alternations of the base and tool fits.

    Returns
    -------
    base2tracker, flange2tool : ndarray, shape (4, 4)
    """
    base2flange = kinematics.chain(nominal_mdh, obs.q)
    tool = np.array(flange2tool, dtype=float)
    base = np.eye(4)
    for _ in range(iterations if not tool_known else 1):
        if frame == "tracker":
            model = base2flange[:, :3, :3] @ tool[:3, 3] + base2flange[:, :3, 3]
            base = frames.fit_rigid(model, obs.points)
        if tool_known:
            break
        tool[:3, 3] = tool_point(base2flange, base, obs.points)
    if obs.rotations is not None and not tool_known:  # has_orientation
        tool[:3, :3] = tool_rotation(base2flange, base, obs.rotations)

    return base, tool
