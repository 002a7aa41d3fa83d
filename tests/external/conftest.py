"""Shared by the external-robot tests: one checked 40-pose plan, made once per session.

Made as a user makes it (``calibrator plan``), for a reflector 14 mm from the
default guess (``--tool 11.3,-6.8,96.2``). The runs take it through
``external_cell_kit.first_poses`` (its first poses, vias included, without the
record of the reflector it was made for), so they measure with the default
guess and the association must find the reflector itself.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from cli_process_kit import run_cli
from external_cell_kit import TOOL_MM


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
