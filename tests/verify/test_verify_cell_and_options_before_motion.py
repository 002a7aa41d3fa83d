"""``verify --cell`` and ``measure --cell``: the cell file's obstacles and tracker are used.

Every option is checked before the first motion: a refused option leaves
no journal, no session and no figures behind.
"""

import numpy as np
import pandas as pd
import pytest
from cli_kit import cli, listing, one_line_error

from calibrator import robots
from calibrator.model import frames, kinematics

ARM = robots.get("ur10e")


def _cell(tmp_path, text):
    (tmp_path / "cell.yaml").write_text(text)
    return listing(tmp_path)


def test_verify_refuses_a_cube_in_an_obstacle_of_its_cell_file(tmp_path):
    before = _cell(
        tmp_path,
        "obstacles:\n  - box: {name: jig, min_mm: [650, 50, 250], max_mm: [750, 150, 350]}\n",
    )
    args = ("verify", "-q", "--cycles", "2", "--cube", "700,100,300,200", "-o", "v.json")
    line = one_line_error(cli(*args, "--cell", "cell.yaml", cwd=tmp_path))
    assert line.startswith("calibrator: error: --cube") and "the cell allows" in line
    assert listing(tmp_path) == before


def test_verify_refuses_its_cell_files_tracker_inside_the_reach(tmp_path):
    before = _cell(tmp_path, "tracker:\n  at_mm: [400, 0, 300]\n")
    line = one_line_error(cli("verify", "--cycles", "2", "--cell", "cell.yaml", cwd=tmp_path))
    assert "inside the ur10e's reach" in line
    assert listing(tmp_path) == before


def test_verify_default_cube_keeps_clear_of_the_cell_files_obstacle(tmp_path):
    _cell(
        tmp_path,
        "obstacles:\n  - box: {name: jig, min_mm: [300, -1500, -100], max_mm: [1500, 1500, 250]}\n",
    )
    done = cli("verify", "-q", "--cycles", "2", "--cell", "cell.yaml", "-o", "v.json", cwd=tmp_path)
    assert done.code == 0, done.stderr
    table = pd.read_parquet(tmp_path / "v.parquet")
    commanded = table[["cmd_x_mm", "cmd_y_mm", "cmd_z_mm"]].to_numpy()
    inside = np.all((commanded >= [300, -1500, -100]) & (commanded <= [1500, 1500, 250]), axis=1)
    assert not inside.any()


@pytest.mark.parametrize("frame", ["0,0,0,1e308,0,0", "1e308,0,0,0,0,0", "0,0,0,7,0,0"])
def test_verify_base_frame_is_refused_before_anything_moves(tmp_path, frame):
    line = one_line_error(
        cli("verify", "--cycles", "2", "--base-frame", frame, "-o", "v.json", cwd=tmp_path)
    )
    assert "--base-frame" in line
    assert list(tmp_path.iterdir()) == []


def test_measure_refuses_the_cell_files_tracker_inside_the_reach_with_the_sim_tracker(tmp_path):
    before = _cell(tmp_path, "tracker:\n  at_mm: [400, 0, 300]\n")
    line = one_line_error(
        cli("measure", "--poses", "12", "--cell", "cell.yaml", "-o", "s.parquet", cwd=tmp_path)
    )
    assert "inside the ur10e's reach" in line
    assert listing(tmp_path) == before


def test_measure_puts_the_sim_tracker_where_the_cell_file_says(tmp_path):
    at = np.array([-400.0, 2600.0, 500.0])
    _cell(tmp_path, f"tracker:\n  at_mm: [{at[0]}, {at[1]}, {at[2]}]\n")
    done = cli(
        "measure", "-q", "--poses", "12", "--cell", "cell.yaml", "-o", "s.parquet", cwd=tmp_path
    )
    assert done.code == 0, done.stderr
    table = pd.read_parquet(tmp_path / "s.parquet")
    q = table[[f"q{i}_rad" for i in range(1, 7)]].to_numpy()
    # Ranges from the tracker (its frame's origin) match the nominal arm seen from
    # the cell file's position within the hidden errors (a few mm), not from the default.
    tool = frames.transform(translation=(0.0, 0.0, 100.0))
    nominal = kinematics.forward(ARM.mdh, q, tool)[:, :3, 3]
    measured = np.linalg.norm(table[["x_mm", "y_mm", "z_mm"]].to_numpy(), axis=1)
    expected = np.linalg.norm(nominal - at, axis=1)
    assert np.max(np.abs(measured - expected)) < 10.0
