"""The robot cell: the arm as capsules, its surroundings, and the checks a plan must pass.

Build an arm's capsule model with :func:`arm_geometry`, read a cell file with
:func:`read_cell`, and check with :func:`check_plan` (a whole plan: every
pose and every motion, vias included) before anything moves::

    from calibrator.cell import Cell, check_plan
    from calibrator import robots
    from calibrator.plan import Plan

    check_plan(plan, robots.get("ur10e"), Cell(tracker_at_mm=(2500, 400, 300)), (0, 0, 100))

Everything is in the robot base frame, mm and rad; nothing here touches hardware.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from calibrator.cell.cellfile import Box, Cell, CellError, Cylinder, parse_cell, read_cell
from calibrator.cell.checks import (
    MOTION_REASONS,
    REASONS,
    Checker,
    check_tracker_placement,
    checker,
    describe,
    motion_faults,
    pose_faults,
)
from calibrator.cell.geometry import ArmGeometry, Capsule, arm_geometry, place
from calibrator.cell.timing import CellTime, cell_time, move_times, order_poses, time_matrix

if TYPE_CHECKING:
    from calibrator import robots
    from calibrator.plan import Plan

__all__ = [
    "MOTION_REASONS",
    "REASONS",
    "ArmGeometry",
    "Box",
    "Capsule",
    "Cell",
    "CellError",
    "CellTime",
    "Checker",
    "Cylinder",
    "arm_geometry",
    "cell_time",
    "check_plan",
    "check_tracker_placement",
    "check_whole_plan",
    "checker",
    "describe",
    "estimate",
    "motion_faults",
    "move_times",
    "order_poses",
    "parse_cell",
    "place",
    "pose_faults",
    "read_cell",
    "time_matrix",
]


def check_whole_plan(
    plan: Plan,
    model: robots.RobotDescription,
    cell: Cell,
    tool_mm: ArrayLike,
    *,
    home_rad: ArrayLike | None = None,
    need: int = 0,
) -> Plan:
    """Everything a plan must pass before its first motion, whoever runs it.

    The one gate of ``measure`` (any robot) and ``program`` (the only gate
    for an arm the controller runs on its own), and of ``verify``'s test
    poses: the joint limits of every pose, via and home pose; enough poses;
    then :func:`check_plan` (the cell, the tracker, every motion, those from
    and back to home included).

    Parameters
    ----------
    plan : calibrator.plan.Plan
    model : calibrator.robots.RobotDescription
    cell : Cell
        With its tracker position when known (the aim checks run only then).
    tool_mm : array_like, shape (3,)
        Reflector position on the flange, mm.
    home_rad : array_like, shape (6,), optional
        The pose the program starts and ends at, rad; its two moves are checked.
    need : int
        Fewest measured poses (what identification needs).

    Returns
    -------
    calibrator.plan.Plan
        The plan, as checked.

    Raises
    ------
    calibrator.errors.CalibrationError
        ``PlanError`` (limits, count) or :class:`CellError`, naming the first
        bad pose, via or motion and why.
    """
    from calibrator import plan as plans

    plans.validate(plan.q_rad, model.joint_limits_rad, need=need)
    for pose, via in enumerate(plan.via_rad):
        if len(via):
            try:
                plans.validate(via, model.joint_limits_rad)
            except plans.PlanError as exc:
                raise plans.PlanError(f"via poses before pose {pose}: {exc}") from None
    if home_rad is not None:
        try:
            plans.validate(np.reshape(home_rad, (1, 6)), model.joint_limits_rad)
        except plans.PlanError as exc:
            raise plans.PlanError(f"home pose: {exc}") from None
    check_plan(plan, model, cell, tool_mm, home_rad=home_rad)
    return plan


def check_plan(
    plan: Plan,
    model: robots.RobotDescription,
    cell: Cell,
    tool_mm: ArrayLike,
    *,
    home_rad: ArrayLike | None = None,
) -> None:
    """Check a whole plan in its cell before the first motion.

    Every measured pose passes all of :data:`REASONS` (the tracker's only when
    the cell has a tracker position), every via pose and the home pose the
    collision ones, and every motion between consecutive rows (vias included,
    and from home to the first row and from the last pose back home) the
    collision ones along its whole joint-space line.

    Parameters
    ----------
    plan : calibrator.plan.Plan
        Measured poses ``q_rad`` (N, 6) and the vias before each.
    model : calibrator.robots.RobotDescription
    cell : Cell
    tool_mm : array_like, shape (3,)
        Reflector position on the flange, mm.
    home_rad : array_like, shape (6,), optional
        Start and end pose of a program, rad.

    Raises
    ------
    CellError
        Naming the first bad pose (by its number) or motion (by its ends) and why.
    """
    chk = checker(arm_geometry(model.name, model.mdh, tool_mm), cell)
    check_tracker_placement(chk)
    faults = pose_faults(chk, plan.q_rad)
    bad = np.flatnonzero(faults.any(axis=1))
    if bad.size:
        i = int(bad[0])
        reason = REASONS[int(np.argmax(faults[i]))]
        more = f" ({bad.size} poses fail)" if bad.size > 1 else ""
        raise CellError(
            f"plan pose {i}: {reason}: {describe(chk, plan.q_rad[i], reason)}{more}; nothing moved"
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
    via_faults = pose_faults(chk, path)[:, : len(MOTION_REASONS)]
    for r in np.flatnonzero(via_faults.any(axis=1)):
        reason = MOTION_REASONS[int(np.argmax(via_faults[r]))]
        raise CellError(
            f"plan {labels[r]}: {reason}: {describe(chk, path[r], reason)}; nothing moved"
        )
    if len(path) > 1:
        moves = motion_faults(chk, path[:-1], path[1:])
        for m in np.flatnonzero(moves.any(axis=1)):
            reason = MOTION_REASONS[int(np.argmax(moves[m]))]
            raise CellError(
                f"plan motion from {labels[m]} to {labels[m + 1]}: {reason} along the way; "
                "nothing moved"
            )


def estimate(
    plan: Plan,
    model: robots.RobotDescription,
    speed_rad_s: float,
    accel_rad_s2: float,
    **kwargs: Any,
) -> CellTime:
    """:func:`cell_time` of a :class:`calibrator.plan.Plan` (all its rows, vias included).

    ``speed_rad_s`` and ``accel_rad_s2`` are lowered to the model's caps;
    ``kwargs`` go to :func:`cell_time` (``settle_s``, ``readings``, ``rate_hz``).
    """
    speed = min(speed_rad_s, model.move_speed_cap_rad_s)
    accel = min(accel_rad_s2, model.move_accel_cap_rad_s2)
    return cell_time(plan.path_rad, len(plan.q_rad), speed, accel, **kwargs)
