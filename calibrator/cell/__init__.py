"""The robot cell: the arm as capsules, its surroundings, and the checks a plan must pass.

Build an arm's capsule model with :func:`arm_geometry`, read a cell file with
:func:`read_cell`, and check poses (:func:`pose_faults`) and motions
(:func:`motion_faults`). A whole plan is checked with these before anything
moves by :func:`calibrator.planning.check_plan`::

    from calibrator import robots
    from calibrator.cell import Cell
    from calibrator.planning import check_plan

    check_plan(plan, robots.get("ur10e"), Cell(tracker_at_mm=(2500, 400, 300)), (0, 0, 100))

Everything is in the robot base frame, mm and rad; nothing here touches hardware.
"""

from __future__ import annotations

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
    "check_tracker_placement",
    "checker",
    "describe",
    "motion_faults",
    "move_times",
    "order_poses",
    "parse_cell",
    "place",
    "pose_faults",
    "read_cell",
    "time_matrix",
]
