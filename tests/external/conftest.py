"""Shared by the external-robot tests: one checked 40-pose plan, made once per session.

Made as a user makes it (``calibrator plan``), for a reflector 14 mm from the
default guess (``--tool 11.3,-6.8,96.2``): the runs below measure with the
default guess, so the association must find the reflector itself. Tests that
need fewer poses take the plan's first ones (``external_cell.first_poses``), vias
included, instead of planning again.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from cli_process import run_cli
from external_cell import TOOL_MM


@pytest.fixture(scope="session")
def plan40(tmp_path_factory) -> Path:
    """``plan.csv``: 40 poses, tracker at 2500,400,300, ``--tool 11.3,-6.8,96.2``, seed 1."""
    cwd = tmp_path_factory.mktemp("plan40")
    done = run_cli(
        "plan", "--poses", "40", "--tracker-at", "2500,400,300", "--seed", "1",
        "--tool", ",".join(map(str, TOOL_MM)), "-o", "plan.csv", cwd=cwd,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    return cwd / "plan.csv"
