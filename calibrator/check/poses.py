"""Check poses: few, and chosen for what drifts.

The planner of ``calibrator plan`` (:func:`calibrator.planning.make_checked`:
every pose and move clear of the arm, the mounting plane and the cell,
facing the tracker, in time order) picks them D-optimally for the
parameters that drift: the joint zeros, the base and the reflector on the
flange. Joint 1's zero turns the arm as the base's turn about its axis does,
and joint 6's moves the reflector as a shift on the flange does, so the
choice serves the base, the reflector and joints 2 to 5 (the explanation
still tries joints 1 and 6 on their own).
"""

from __future__ import annotations

from typing import Any

from numpy.typing import ArrayLike

from calibrator.model import parameters

#: Check poses by default.
DEFAULT_POSES = 8
#: What the choice serves.
DRIFT_NAMES = (
    ("theta2", "theta3", "theta4", "theta5") + parameters.BASE_NAMES + parameters.TOOL_NAMES
)


def choose(model: Any, n: int, cell: Any, tool_mm: ArrayLike, seed: int = 0) -> Any:
    """A checked, ordered plan of ``n`` check poses.

    Parameters
    ----------
    model : calibrator.robots.RobotDescription
    n : int
        At least 5 (the drift parameters need 13 rows or more).
    cell : calibrator.cell.Cell
        With the tracker's position, if known.
    tool_mm : array_like, shape (3,)
        Reflector on the flange, mm.

    Returns
    -------
    calibrator.planning.PlanReport
    """
    from calibrator import planning

    return planning.make_checked(model, n, cell, tool_mm, seed=seed, names=DRIFT_NAMES)
