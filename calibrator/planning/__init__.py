"""Pose plans: what to measure, in what order, checked whole before any motion.

A plan is an array of joint targets, shape (N, 6), rad, with vias between
them, made from a candidate set (scrambled Halton points, seeded random
points, or the user's own CSV of joint angles), filtered by every check of
the cell, reduced to the N most informative poses and ordered for time.

Modules, each with one job:

- :mod:`~calibrator.planning.plan`: the :class:`Plan` type every stage passes
  (a leaf: it imports nothing of the cell or the planner);
- :mod:`~calibrator.planning.planfile`: plan CSV files, read and written, and
  :func:`made_for` (a plan's file records the arm, tracker and tool it holds for);
- :mod:`~calibrator.planning.sampling`: the joint box, seeded candidates, duplicates;
- :mod:`~calibrator.planning.design`: observability and D-optimal selection;
- :mod:`~calibrator.planning.ordering`: a short-time order with safe moves and vias;
- :mod:`~calibrator.planning.planner`: the cell-aware planner (:func:`make_checked`);
- :mod:`~calibrator.planning.checks`: the one whole-plan check before motion.

Joint angles rad, lengths mm, positions in the robot base frame.
"""

from calibrator.planning.checks import check_arm_limits, check_limits, check_plan
from calibrator.planning.design import (
    ANGLE_SCALE_MM,
    Observability,
    log_det,
    min_poses,
    min_singular,
    observability,
    select_d_optimal,
)
from calibrator.planning.ordering import estimate
from calibrator.planning.plan import Plan, PlanError, PlanOrigin, digest, point_text
from calibrator.planning.planfile import (
    DEFAULT_TOOL_MM,
    DEG_COLUMNS,
    JOINT_COLUMNS,
    ORIGIN_COLUMNS,
    ORIGIN_TOLERANCE_MM,
    made_for,
    plan_text,
    read_csv,
    read_plan,
    write_plan,
)
from calibrator.planning.planner import (
    MAX_SAMPLED,
    SELECTIONS,
    PlanReport,
    guessed_geometry,
    make_checked,
)
from calibrator.planning.sampling import DUPLICATE_RAD, distinct, joint_box, sample

__all__ = [
    "ANGLE_SCALE_MM",
    "DEFAULT_TOOL_MM",
    "DEG_COLUMNS",
    "DUPLICATE_RAD",
    "JOINT_COLUMNS",
    "MAX_SAMPLED",
    "ORIGIN_COLUMNS",
    "ORIGIN_TOLERANCE_MM",
    "SELECTIONS",
    "Observability",
    "Plan",
    "PlanError",
    "PlanOrigin",
    "PlanReport",
    "check_arm_limits",
    "check_limits",
    "check_plan",
    "digest",
    "distinct",
    "estimate",
    "joint_box",
    "log_det",
    "made_for",
    "guessed_geometry",
    "make_checked",
    "min_poses",
    "min_singular",
    "observability",
    "plan_text",
    "point_text",
    "read_csv",
    "read_plan",
    "sample",
    "select_d_optimal",
    "write_plan",
]
