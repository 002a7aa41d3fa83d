"""Target compensation: joint angles and corrected targets for a calibrated arm.

A controller keeps its nominal model. To make the real (calibrated) arm
reach a desired tool pose ``T`` (robot base frame):

1. solve the calibrated model's inverse kinematics, ``FK_cal(q) = T``, by
   damped Newton steps started from the nominal solution ``q_nom``;
2. the corrected target is ``FK_nom(q)``: sent to the controller, its
   nominal inverse kinematics returns ``q`` and the real arm lands on ``T``.

Both models carry the calibration's ``flange2tool``: the controller's TCP is
assumed to be the identified tool. Everything is vectorised over targets.

The inverse kinematics is :func:`calibrator.model.inverse.solve` (damped
Newton on the geometric Jacobian); a result outside the joint limits is
reported, never clipped.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from calibrator.model import inverse, joint_terms, kinematics, rotations
from calibrator.model.inverse import Solution

if TYPE_CHECKING:
    from calibrator.calibration import Calibration


#: Largest turn of a joint between a target's nominal and calibrated solution
#: (deg). A calibration moves joints by tenths of a degree (about 1 deg for
#: the large errors of the simulated arms); much more means the
#: target sits near a singularity, where a tiny pose change swings the wrist
#: or the arm, and the corrected target would not move the arm as planned.
MAX_JOINT_CHANGE_DEG = 5.0


@dataclass(frozen=True)
class Compensation:
    """What :func:`compensate` found.

    Attributes
    ----------
    q : ndarray, shape (N, 6)
        Joint angles of the calibrated arm reaching the targets (rad).
    corrected : ndarray, shape (N, 4, 4)
        Targets to send to a controller keeping its nominal model (mm).
    desired : ndarray, shape (N, 4, 4)
    solution : Solution
    q_nominal : ndarray, shape (N, 6)
        Nominal model's joints for the desired poses (the IK's start).
    """

    q: np.ndarray
    corrected: np.ndarray
    desired: np.ndarray
    solution: Solution
    q_nominal: np.ndarray


def compensate(
    calibration: Calibration,
    desired: ArrayLike | None = None,
    q_nominal: ArrayLike | None = None,
    limits: ArrayLike | None = None,
    payload_kg: float | None = None,
    tool: ArrayLike | None = None,
    nominal_solved: bool = False,
) -> Compensation:
    """Compensate targets for a calibrated arm.

    Parameters
    ----------
    calibration : calibrator.calibration.Calibration
    desired : array_like, shape (N, 4, 4), optional
        Desired tool poses (base frame, mm). Without them the desired poses are
        the nominal model's poses at ``q_nominal`` (an existing program's
        joint targets).
    q_nominal : array_like, shape (N, 6)
        Nominal joint solution of each target (rad): the IK's start. With
        ``desired`` it is refined on the nominal model first.
    limits : array_like, shape (6, 2), optional
        Joint limits (rad).
    payload_kg : float, optional
        Working payload for the calibration's compliance terms (default: the
        payload it was calibrated at).
    tool : array_like, shape (4, 4) or (N, 4, 4), optional
        The controller's TCP (flange to tool, mm), one or one per target
        (default: the calibration's ``flange2tool``).
    nominal_solved : bool
        ``q_nominal`` already is the nominal solution of ``desired`` (a
        program filter solved it in the target's configuration): not refined.

    Returns
    -------
    Compensation
    """
    tool = calibration.flange2tool if tool is None else np.asarray(tool, dtype=float)
    if q_nominal is None:
        # A default only because ``desired`` before it has one: the solver must start somewhere.
        raise ValueError("q_nominal is required: the nominal joints of each target")
    q_nominal = kinematics.check_joints(q_nominal)

    if desired is None:
        desired = kinematics.tool_poses(calibration.nominal_mdh, q_nominal, tool)
    else:
        desired = np.asarray(desired, dtype=float)
        if not nominal_solved:
            q_nominal = inverse.solve(calibration.nominal_mdh, desired, q_nominal, tool).q
    sol = inverse.solve(calibration.mdh, desired, q_nominal, tool, limits)
    # Joint terms: the IK gives the angles the joints must really turn to;
    # command the read-back angles whose effective angles those are.
    terms = calibration.joint_terms
    if terms.used:
        from calibrator.robots import masses

        torque = joint_terms.torque_function(
            terms, calibration.nominal_mdh, masses.for_terms(terms), payload_kg
        )
        q_cmd = joint_terms.invert(sol.q, terms, torque)
        inside = np.ones(len(q_cmd), dtype=bool)
        if limits is not None:
            lim = np.asarray(limits, dtype=float)
            inside = np.all((q_cmd >= lim[:, 0]) & (q_cmd <= lim[:, 1]), axis=1)
        sol = replace(sol, q=q_cmd, within_limits=inside)
    corrected = kinematics.tool_poses(calibration.nominal_mdh, sol.q, tool)
    return Compensation(sol.q, corrected, desired, sol, q_nominal)


def correction_sizes(result: Compensation, q_nominal: np.ndarray | None = None) -> dict:
    """How big each target's correction is.

    Parameters
    ----------
    result : Compensation
    q_nominal : ndarray, shape (N, 6), optional
        The program's nominal joints; defaults to the nominal model's IK of
        the desired poses (what the solver started from).

    Returns
    -------
    dict of ndarray, shape (N,)
        ``correction_mm``: distance from the desired to the corrected
        target (mm); ``correction_mrad``: turn between them (mrad);
        ``joint_correction_mrad``: largest ``|q_calibrated - q_nominal|``
        over the joints (mrad).
    """
    move = result.corrected[:, :3, 3] - result.desired[:, :3, 3]
    turn = rotations.rotation_error(result.corrected[:, :3, :3], result.desired[:, :3, :3])
    out = {
        "correction_mm": np.linalg.norm(move, axis=1),
        "correction_mrad": 1e3 * np.linalg.norm(turn, axis=1),
    }
    if q_nominal is not None:
        out["joint_correction_mrad"] = 1e3 * np.max(np.abs(result.q - q_nominal), axis=1)
    else:
        out["joint_correction_mrad"] = 1e3 * np.max(np.abs(result.q - result.q_nominal), axis=1)
    return out
