"""The one check of a whole plan before its first motion, whoever runs it.

``measure`` (any robot), ``program`` (the only gate for an arm the
controller runs on its own) and ``verify``'s test poses call
:func:`check_plan`: the joint limits of every pose, via and home pose,
enough poses, then every pose, via and motion in the cell
(:mod:`calibrator.cell`: the arm's capsules, the cell's obstacles, the
tracker). Nothing moves unless the whole plan passes.

A robot driver keeps its own last-line check of the targets it is sent
(``drivers.robot.safety``): drivers take plain joint arrays and do not
depend on the planner.

Joint angles rad, lengths mm, positions in the robot base frame.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from calibrator import cell as cells
from calibrator.planning.plan import Plan, PlanError

if TYPE_CHECKING:
    from calibrator import robots


def check_limits(q: ArrayLike, joint_limits_rad: ArrayLike, *, need: int = 0) -> np.ndarray:
    """Check joint vectors before any motion: shape, finite, inside limits, enough poses.

    Parameters
    ----------
    q : array_like, shape (N, 6)
        Joint angles, rad.
    joint_limits_rad : array_like, shape (6, 2)
        ``[min, max]`` of each joint, rad.
    need : int
        Fewest rows.

    Returns
    -------
    ndarray, shape (N, 6)

    Raises
    ------
    PlanError
        Naming the first offending row and joint, or the shortfall.
    """
    q = np.asarray(q, dtype=float)
    if q.ndim != 2 or q.shape[1] != 6:
        raise PlanError(f"a plan needs 6 joint angles per pose, got shape {q.shape}")
    limits = np.asarray(joint_limits_rad, dtype=float)
    bad = ~((q >= limits[:, 0]) & (q <= limits[:, 1]))  # NaN fails both
    if bad.any():
        row, joint = np.argwhere(bad)[0]
        raise PlanError(
            f"plan row {row} joint {joint + 1}: {q[row, joint]:.6g} rad outside "
            f"[{limits[joint, 0]:.6g}, {limits[joint, 1]:.6g}]; nothing moved"
        )
    if len(q) < need:
        raise PlanError(f"plan has {len(q)} poses; the free parameters need at least {need}")
    return q


def check_arm_limits(q: ArrayLike, model: robots.RobotDescription, *, need: int = 0) -> np.ndarray:
    """:func:`check_limits` against an arm's limits, said in its controller's angles.

    Parameters
    ----------
    q : array_like, shape (N, 6)
        The model's joint angles, rad.
    model : calibrator.robots.RobotDescription
        Its :meth:`~calibrator.robots.RobotDescription.outside_limits` is the rule
        (a coupled joint's stated controller limits included).
    need : int
        Fewest rows.
    """
    q = check_limits(q, np.tile([-np.inf, np.inf], (6, 1)), need=need)  # shape, NaN, count
    breach = model.limit_breach(q)
    if breach is not None:
        row, what = breach
        raise PlanError(f"plan row {row} {what}; nothing moved")
    return q


def check_plan(
    plan: Plan,
    model: robots.RobotDescription,
    cell: cells.Cell,
    tool_mm: ArrayLike,
    *,
    home_rad: ArrayLike | None = None,
    need: int = 0,
) -> Plan:
    """Everything a plan must pass before its first motion, whoever runs it.

    The joint limits of every pose, via and home pose; enough poses; then
    every measured pose passes all of :data:`calibrator.cell.REASONS` (the
    tracker's only when the cell has a tracker position), every via pose and
    the home pose the collision ones, and every motion between consecutive
    rows (vias included, and from home to the first row and from the last
    pose back home) the collision ones along its whole joint-space line.

    Parameters
    ----------
    plan : Plan
    model : calibrator.robots.RobotDescription
    cell : calibrator.cell.Cell
        With its tracker position when known (the aim checks run only then).
    tool_mm : array_like, shape (3,)
        Reflector position on the flange, mm.
    home_rad : array_like, shape (6,), optional
        The pose a program starts and ends at, rad; its two moves are checked.
    need : int
        Fewest measured poses (what identification needs).

    Returns
    -------
    Plan
        The plan, as checked.

    Raises
    ------
    PlanError
        Limits or count, naming the first bad pose, via or the shortfall.
    calibrator.cell.CellError
        Naming the first bad pose (by its number), via or motion (by its
        ends) and why; also a tracker placed where the arm could reach it.
    """
    check_arm_limits(plan.q_rad, model, need=need)
    for pose, via in enumerate(plan.via_rad):
        if len(via):
            try:
                check_arm_limits(via, model)
            except PlanError as exc:
                raise PlanError(f"via poses before pose {pose}: {exc}") from None
    if home_rad is not None:
        try:
            check_arm_limits(np.reshape(home_rad, (1, 6)), model)
        except PlanError as exc:
            raise PlanError(f"home pose: {exc}") from None
    _check_in_cell(plan, model, cell, tool_mm, home_rad)
    return plan


def _check_in_cell(
    plan: Plan,
    model: robots.RobotDescription,
    cell: cells.Cell,
    tool_mm: ArrayLike,
    home_rad: ArrayLike | None,
) -> None:
    """The cell part of :func:`check_plan`: poses, vias, home and every motion."""
    chk = cells.checker(cells.arm_geometry(model.name, model.mdh, tool_mm), cell)
    cells.check_tracker_placement(chk)
    faults = cells.pose_faults(chk, plan.q_rad)
    bad = np.flatnonzero(faults.any(axis=1))
    if bad.size:
        i = int(bad[0])
        reason = cells.REASONS[int(np.argmax(faults[i]))]
        more = f" ({bad.size} poses fail)" if bad.size > 1 else ""
        raise cells.CellError(
            f"plan pose {i}: {reason}: {cells.describe(chk, plan.q_rad[i], reason)}{more}; "
            "nothing moved"
        )
    rows, labels = [], []
    for i, q in enumerate(plan.q_rad):
        for k, v in enumerate(plan.via_rad[i]):
            rows.append(v)
            labels.append(f"via {k} before pose {i}")
        rows.append(q)
        labels.append(f"pose {i}")
    if home_rad is not None:
        # A program leaves home for the first row and returns from the last pose.
        home = np.asarray(home_rad, dtype=float).reshape(6)
        rows = [home, *rows, home]
        labels = ["home", *labels, "home"]
    path = np.asarray(rows, dtype=float)
    motion_reasons = cells.MOTION_REASONS
    via_faults = cells.pose_faults(chk, path)[:, : len(motion_reasons)]
    for r in np.flatnonzero(via_faults.any(axis=1)):
        reason = motion_reasons[int(np.argmax(via_faults[r]))]
        raise cells.CellError(
            f"plan {labels[r]}: {reason}: {cells.describe(chk, path[r], reason)}; nothing moved"
        )
    if len(path) > 1:
        moves = cells.motion_faults(chk, path[:-1], path[1:])
        for m in np.flatnonzero(moves.any(axis=1)):
            reason = motion_reasons[int(np.argmax(moves[m]))]
            raise cells.CellError(
                f"plan motion from {labels[m]} to {labels[m + 1]}: {reason} along the way; "
                "nothing moved"
            )
