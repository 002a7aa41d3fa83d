"""The check run from Python (``calibrator.check.procedure.run``), as its module's docstring shows.

The command (``calibrator check``) prepares the check and runs the cell
sequence itself; a script calls :func:`calibrator.check.procedure.run`, which
must do the same: choose the poses, measure them with the given devices,
tell the given operator each step, write check.json and its poses, and
return the document it wrote.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from cli_kit import cli

from calibrator import calibration, robots
from calibrator.acquire import procedure
from calibrator.check import procedure as check
from drivers.devices import Devices


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    """A UR10e of the simulated cell (seed 3) measured on 12 poses and identified."""
    folder = tmp_path_factory.mktemp("check_py")
    done = cli("measure", "--model", "ur10e", "--seed", "3", "--poses", "12", "-o", "s.parquet",
               "-q", cwd=folder)  # fmt: skip
    assert done.code == 0, done.stderr
    assert cli("identify", "s.parquet", "-o", "cal.json", "-q", cwd=folder).code == 0
    return folder


class _Told(procedure.Operator):
    """An operator that notes the steps it is told."""

    def __init__(self) -> None:
        self.steps: list[str] = []

    def step(self, name: str) -> None:
        self.steps.append(name)


def test_a_check_run_from_python_writes_its_document_and_tells_its_operator(calibrated):
    path = Path(calibrated) / "cal.json"
    cal = calibration.load(path)
    operator = _Told()
    out = Path(calibrated) / "py.json"
    result = check.run(
        robots.get(cal.model), check.Options(cal, path, poses=5, seed=3), out, Devices(), operator
    )
    assert result.document is not None
    assert result.document["verdict"] == "ok"
    # The document returned is the one written, beside its poses.
    assert json.loads(out.read_text()) == json.loads(json.dumps(result.document))
    assert out.with_suffix(".parquet").exists()
    assert len(result.document["poses"]) == 5
    assert result.document["calibration"] == str(path)
    assert len(result.summary.measured) == 5 and result.summary.complete
    assert result.summary.written == out
    assert operator.steps[0] == "connected" and "written" in operator.steps
