"""The planner's last refusal: no joined choice within its cap on orderings.

Each round of :func:`calibrator.planning.planner._choose_joined` orders a
choice and drops the poses no safe move joins; after
:data:`~calibrator.planning.planner.MAX_ROUNDS` orderings it stops, saying
how many of the poses the last one joined, how many it replaced and the
reasons of the moves that were unsafe. The cap is 40 orderings of about a
second each; the wall cell of ``test_joined.py`` needs two (its first
choice leaves one pose unjoined), so with the cap lowered to one the
refusal is reached in one ordering.
"""

from __future__ import annotations

import pytest

from calibrator import cell as cells
from calibrator import planning, robots
from calibrator.planning import planner

WALL = cells.Box("wall", (-3000.0, -10.0, -100.0), (-300.0, 10.0, 3000.0))
WALLED = cells.Cell(tracker_at_mm=(2500.0, 400.0, 300.0), boxes=(WALL,))


def test_running_out_of_orderings_says_how_many_were_joined_and_why_not_the_rest(monkeypatch):
    monkeypatch.setattr(planner, "MAX_ROUNDS", 1)
    with pytest.raises(planning.PlanError) as caught:
        planning.make_checked(
            robots.get("ur10e"), 12, WALLED, (0.0, 0.0, 100.0), seed=1, n_candidates=3000
        )
    assert str(caught.value) == (
        "found 11 of 12 poses joined by safe moves after 1 choices, no safe move joined 1 to "
        "the other poses (self collision 1, obstacle 1); "
        "more candidates, another tracker position or fewer poses?"
    )
