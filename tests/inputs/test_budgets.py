"""Budget callbacks of calibrator.cli._checks: the limit itself passes, one more is refused."""

import os

import pytest
import typer

from calibrator.cli import _checks as checks
from calibrator.inputs.errors import StrictError


@pytest.mark.parametrize(
    "budget", ["plan_poses", "candidates", "simulate_poses", "trials", "samples"]
)
def test_a_count_passes_up_to_its_limit(budget):
    limit = int(checks.BUDGETS[budget][0])
    check = checks.count(budget)
    assert check(limit) == limit and check(1) == 1 and check(None) is None
    with pytest.raises(typer.BadParameter, match=f"{limit + 1} .* more than the limit of {limit}"):
        check(limit + 1)
    with pytest.raises(typer.BadParameter, match="must be a whole number >= 1, got 0"):
        check(0)


def test_workers_are_bounded_by_the_cores():
    cores = os.cpu_count()
    assert checks.cores()(cores) == cores
    with pytest.raises(typer.BadParameter, match=f"at most {cores} .*got {cores + 1}"):
        checks.cores()(cores + 1)


def test_seconds_and_seeds():
    assert checks.seconds("settle")(60.0) == 60.0
    for bad in (60.5, 1e9, float("nan"), -1.0):
        with pytest.raises(typer.BadParameter):
            checks.seconds("settle")(bad)
    assert checks.seed()(2**63 - 1) == 2**63 - 1
    for bad in (-1, 2**63):
        with pytest.raises(typer.BadParameter, match=r">= 0 and <= 2\*\*63 - 1"):
            checks.seed()(bad)


@pytest.mark.parametrize(
    "text", ["0,0,1e308", "0,0,2000.5", "0,0", "0,0,nan", "0_5,0,0", "1,2,3,4"]
)
def test_a_point_outside_a_cell_or_the_grammar_is_refused(text):
    with pytest.raises(typer.BadParameter):
        checks.point_mm("tool")(text)


def test_a_point_in_the_cell_is_returned_as_given():
    assert checks.point_mm("tool")(" 0, -2000, 100.5") == " 0, -2000, 100.5"
    assert checks.point_mm("tracker_at")(None) is None


def test_plan_work_counts_the_default_candidates():
    checks.plan_work(30, None, "d-optimal")  # 2000 candidates by default
    checks.plan_work(2000, 200_000, "first")  # no selection work
    with pytest.raises(StrictError, match="default for 4000 poses"):
        checks.plan_work(4000, None, "first")
    with pytest.raises(StrictError, match="poses x candidates"):
        checks.plan_work(1000, 30_000, "d-optimal")  # 3e7 selection steps x candidates
    checks.plan_work(1000, 30_000, "random")
