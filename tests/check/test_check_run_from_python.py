"""The check run from Python (``calibrator.check.procedure.run``), as its module's docstring shows.

The command (``calibrator check``) prepares the check and runs the cell
sequence itself; a script calls :func:`calibrator.check.procedure.run`, which
must do the same: choose the poses, measure them with the given devices,
tell the given operator each step, write check.json and its poses, and
return the document it wrote. Its measuring conditions span the first to
the last reading; a tracker placed by the cell (or by the option, which
wins) is moved there, and the poses face it.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from cli_kit import cli

from calibrator import calibration, robots
from calibrator import cell as cells
from calibrator.acquire import procedure
from calibrator.check import poses as check_poses
from calibrator.check import procedure as check
from calibrator.model import frames
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
    # Its format and version, as docs/check.md states them.
    assert (result.document["format"], result.document["version"]) == ("calibrator.check", 1)
    # The document returned is the one written, beside its poses.
    assert json.loads(out.read_text()) == json.loads(json.dumps(result.document))
    assert out.with_suffix(".parquet").exists()
    assert len(result.document["poses"]) == 5
    assert result.document["calibration"] == str(path)
    assert len(result.summary.measured) == 5 and result.summary.complete
    assert result.summary.written == out
    assert operator.steps[0] == "connected" and "written" in operator.steps


def _moved_mm(doc) -> float:
    """How far the check's explanation says the base (or the tracker) moved, mm."""
    found = [re.match(r"the base moved ([0-9.]+) ", line) for line in doc["explanation_text"]]
    moved = [float(m.group(1)) for m in found if m]
    assert len(moved) == 1, doc["explanation_text"]
    return moved[0]


def test_the_runs_span_is_its_first_and_last_reading(calibrated):
    path = Path(calibrated) / "cal.json"
    cal = calibration.load(path)
    out = Path(calibrated) / "span.json"
    doc = check.run(robots.get(cal.model), check.Options(cal, path, poses=5, seed=4), out,
                    Devices()).document  # fmt: skip
    stamps = pq.read_table(out.with_suffix(".parquet")).column("timestamp").to_pylist()
    assert len(set(stamps)) == 5
    conditions = doc["conditions"]
    assert conditions["started"] == min(stamps) == doc["measured_at"]
    assert conditions["ended"] == max(stamps)
    assert conditions["poses_reporting"] == 5


def test_a_tracker_the_cell_places_is_moved_there_and_a_given_position_wins(calibrated):
    """The simulated tracker moves only where the user puts it: by the cell, or by the option.

    The calibration registered the tracker near (2500, 400, 300) mm; a cell file
    placing it 1.5 m to the side moves it there: the check, chosen facing it,
    sees the base 1.5 m off. A position given as the option wins over the
    cell's: the calibration's own estimate, 1.5 mm from where the tracker
    truly stands, moves it by that much only.
    """
    path = Path(calibrated) / "cal.json"
    cal = calibration.load(path)
    arm = robots.get(cal.model)
    estimate = tuple(frames.invert(cal.base2tracker)[:3, 3])
    aside = (estimate[0], estimate[1] + 1500.0, estimate[2])
    tool = tuple(float(v) for v in cal.flange2tool[:3, 3])
    cell = cells.Cell(tracker_at_mm=aside)
    for name, given, at, moved in (
        ("cell", None, aside, 1500.0),
        ("given", estimate, estimate, 0.0),
    ):
        options = check.Options(cal, path, poses=5, seed=3, tracker_at_mm=given, cell=cell)
        doc = check.run(arm, options, Path(calibrated) / f"{name}.json", Devices()).document
        assert doc["verdict"] == "recalibrate"
        assert abs(_moved_mm(doc) - moved) < 5.0, (name, doc["explanation_text"])
        # The poses were chosen facing the tracker where it was put.
        facing = check_poses.choose(arm, 5, cells.Cell().with_tracker(at), tool, seed=3).plan
        shown = np.array([p["q_rad"] for p in doc["poses"]])
        np.testing.assert_allclose(arm.convention.to_controller(facing.q_rad), shown, atol=1e-9)


def test_a_measured_check_shows_the_controllers_joints_as_its_poses_file(tmp_path):
    """KUKA's controller turns joints 1 and 6 the other way: check.json shows its angles."""
    model = "kuka-kr6-r900"
    done = cli("simulate", "--model", model, "--frame", "tracker", "--poses", "24",
               "--seed", "3", "-o", "s.parquet", cwd=tmp_path)  # fmt: skip
    assert done.code == 0, done.stderr
    assert cli("identify", "s.parquet", "-o", "cal.json", "-q", cwd=tmp_path).code == 0
    cal = calibration.load(tmp_path / "cal.json")
    out = tmp_path / "check.json"
    arm = robots.get(model)
    doc = check.run(arm, check.Options(cal, tmp_path / "cal.json", poses=5, seed=3), out,
                    Devices()).document  # fmt: skip
    table = pq.read_table(out.with_suffix(".parquet")).to_pandas()
    q_controller = table[[f"q{i}_rad" for i in range(1, 7)]].to_numpy()
    shown = np.array([p["q_rad"] for p in doc["poses"]])
    np.testing.assert_allclose(shown, q_controller, atol=1e-12)
    # Not the model's angles: joints 1 and 6 turn the other way.
    q_model = arm.convention.to_model(q_controller)
    np.testing.assert_allclose(q_model[:, [0, 5]], -q_controller[:, [0, 5]])
    assert np.abs(q_controller[:, [0, 5]]).min() > 1e-3
