"""The user's candidates may be none at all: refused with the counts, not a crash.

A candidate file with a header and no rows gives an empty (0, 6) set; the
duplicate check (:func:`calibrator.planning.distinct`) must return no rows
for it, and the planner the same sentence as for too few that pass.
"""

from __future__ import annotations

import numpy as np
import pytest

from calibrator import cell as cells
from calibrator import planning, robots


def test_no_joint_vectors_have_no_distinct_rows():
    rows = planning.distinct(np.zeros((0, 6)))
    assert rows.shape == (0,) and rows.dtype.kind == "i"


def test_a_plan_from_no_candidates_is_refused_saying_none_pass():
    cell = cells.Cell(tracker_at_mm=(2500.0, 400.0, 300.0))
    with pytest.raises(planning.PlanError) as caught:
        planning.make_checked(
            robots.get("ur10e"), 12, cell, (0.0, 0.0, 100.0), candidates=np.zeros((0, 6))
        )
    assert str(caught.value).startswith("only 0 of 0 candidates pass the cell's checks")
    assert "12 asked" in str(caught.value)
