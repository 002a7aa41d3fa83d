"""The cell file, and the ``plan`` command in a cell: counts, estimate, refusals."""

import numpy as np
import pytest
from cli_process_kit import run_cli

from calibrator import cell, planning

CELL_YAML = """\
mounting_plane_z_mm: 0
margin_mm: 25
tracker:
  at_mm: [2500, 400, 300]
  min_range_mm: 1000
  max_range_mm: 15000
  acceptance_deg: 30
obstacles:
  - box: {name: table, min_mm: [400, -600, -900], max_mm: [1200, 600, 80]}
  - cylinder: {name: tripod, centre_xy_mm: [2500, 400], radius_mm: 350, z_mm: [-1200, 150]}
"""


def test_cell_file_reads_every_field(tmp_path):
    (tmp_path / "cell.yaml").write_text(CELL_YAML)
    got = cell.read_cell(tmp_path / "cell.yaml")
    assert got.margin_mm == 25.0 and got.mounting_plane_z_mm == 0.0
    assert got.tracker_at_mm == (2500.0, 400.0, 300.0)
    assert (got.min_range_mm, got.max_range_mm, got.acceptance_deg) == (1000.0, 15000.0, 30.0)
    assert got.boxes == (cell.Box("table", (400.0, -600.0, -900.0), (1200.0, 600.0, 80.0)),)
    assert got.cylinders == (cell.Cylinder("tripod", (2500.0, 400.0), 350.0, -1200.0, 150.0),)
    assert cell.parse_cell(None) == cell.Cell()


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("margin: 3\n", "unknown key(s) margin"),
        ("tracker: {at_mm: [1, 2]}\n", "tracker.at_mm: expected a list of 3 numbers"),
        ("margin_mm: .nan\n", "line 1: '.nan' is not a decimal number"),
        ("margin_mm: 1.0e+400\n", "line 1: '1.0e+400' is too large for a number"),
        ("margin_mm: 10000000000000000000000000000000000\n", "is beyond 64 bits"),
        ("margin_mm: 100000\n", "margin_mm: 100000 is not within"),
        ("obstacles:\n  - box: {min_mm: [0, 0, 0], max_mm: [1, 1, 0]}\n", "min_mm must be below"),
        ("obstacles:\n  - sphere: {}\n", "unknown key(s) sphere"),
        ("obstacles:\n  - cylinder: {centre_xy_mm: [0, 0], radius_mm: 1}\n", "missing z_mm"),
        ("tracker: {min_range_mm: 5000, max_range_mm: 100}\n", "min_range_mm must be below"),
        ("[1, 2\n", "not YAML"),
        ("tracker: {acceptance_deg: true}\n", "expected a number, got True"),
    ],
)
def test_bad_cell_files_are_one_clear_error(tmp_path, text, message):
    (tmp_path / "cell.yaml").write_text(text)
    with pytest.raises(
        cell.CellError, match="^" + str(tmp_path / "cell.yaml").replace("\\", "\\\\")
    ) as got:
        cell.read_cell(tmp_path / "cell.yaml")
    assert message in str(got.value)


def test_plan_command_prints_counts_estimate_and_saving(tmp_path):
    (tmp_path / "cell.yaml").write_text(CELL_YAML)
    done = run_cli("plan", "--cell", "cell.yaml", "--poses", "20", "-o", "p.csv", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    first, estimate, wrote = done.stdout.splitlines()
    assert first.startswith("candidates: ") and ", dropped " in first
    assert "acceptance angle" in first and "obstacle" in first
    assert estimate.startswith("estimated cell time ") and "saving " in estimate
    assert wrote.startswith("wrote p.csv: 20 poses")
    plan = planning.read_plan(tmp_path / "p.csv")
    # The plan passes the very check measure makes, in the same cell.
    from calibrator import robots

    planning.check_plan(
        plan, robots.get("ur10e"), cell.read_cell(tmp_path / "cell.yaml"), (0, 0, 100)
    )


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (("--tracker-at", "300,0,0"), "inside the ur10e's reach envelope"),
        (("--cell", "missing.yaml"), "missing.yaml: no such file"),
        (("--from", "same.csv", "--poses", "12"), "are the same pose (1 distinct of 30)"),
        (("--poses", "0"), "--poses"),
    ],
)
def test_plan_command_refusals_are_one_line_exit_2(tmp_path, args, message):
    same = np.tile(np.radians([0, -90, 60, -150, -90, 0.0]), (30, 1))
    planning.write_plan(tmp_path / "same.csv", planning.Plan(same))
    done = run_cli("plan", "-o", "p.csv", *args, cwd=tmp_path)
    assert done.returncode == 2, done.stderr
    assert message in done.stderr and done.stderr.count("\n") == 1, done.stderr
    assert not (tmp_path / "p.csv").exists()
