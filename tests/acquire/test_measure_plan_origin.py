"""A plan file records the arm, tracker and reflector it was made for; measure holds to them."""

import shutil
from pathlib import Path

import numpy as np
import pandas as pd
from cli_kit import cli, listing, one_line_error

from calibrator import planning, robots
from calibrator.model import frames, kinematics


def test_plan_files_record_what_they_were_made_for(tmp_path):
    done = cli("plan", "-o", "p.csv", "--poses", "10", "--tracker-at", "-400,2600,500",
               "--tool", "10,0,90", cwd=tmp_path)  # fmt: skip
    assert done.code == 0, done.stderr
    origin = planning.read_plan(tmp_path / "p.csv").origin
    digest = robots.get("ur10e").digest
    assert origin == planning.PlanOrigin(
        "ur10e", (10.0, 0.0, 90.0), (-400.0, 2600.0, 500.0), digest
    )


def test_a_plan_for_another_description_of_the_same_name_is_refused(tmp_path):
    # A user's description file edited after the plan was made: same name, another arm.
    data = Path(robots.__file__).parent / "data"
    for name in ("kuka-kr6-r900.yaml", "kuka-kr6-r900.urdf"):
        shutil.copy(data / name, tmp_path / name)
    arm = tmp_path / "kuka-kr6-r900.yaml"
    done = cli("plan", "--model", arm.name, "-o", "p.csv", "--poses", "10", cwd=tmp_path)
    assert done.code == 0, done.stderr
    assert planning.read_plan(tmp_path / "p.csv").origin.model_sha256 == robots.get(str(arm)).digest
    arm.write_text(arm.read_text().replace("margin_mm: 10", "margin_mm: 12"))
    before = listing(tmp_path)
    line = one_line_error(
        cli("program", "p.csv", "--model", arm.name, "-o", "cal.src", cwd=tmp_path)
    )
    assert "was made for another description of the" in line
    assert listing(tmp_path) == before


def test_measure_refuses_a_plan_made_for_another_arm_or_tracker(tmp_path, checked_plan):
    planning.write_plan(tmp_path / "plan.csv", checked_plan)
    before = listing(tmp_path)
    line = one_line_error(
        cli("measure", "--plan", "plan.csv", "--model", "ur5e", "-o", "s.parquet", cwd=tmp_path)
    )
    assert "--model ur5e but plan.csv is of a ur10e" in line
    line = one_line_error(
        cli("measure", "--plan", "plan.csv", "--tracker-at", "2500,-400,300", cwd=tmp_path)
    )
    assert "made for the tracker at 2500,400,300 mm, not 2500,-400,300" in line
    assert listing(tmp_path) == before


def test_measure_takes_the_plan_files_tracker_and_tool(tmp_path):
    at = np.array([-400.0, 2600.0, 500.0])
    assert cli("plan", "-o", "p.csv", "--poses", "10", "--tracker-at", "-400,2600,500",
               "--tool", "10,0,90", cwd=tmp_path).code == 0  # fmt: skip
    done = cli("measure", "-q", "--plan", "p.csv", "-o", "s.parquet", cwd=tmp_path)
    assert done.code == 0, done.stderr
    table = pd.read_parquet(tmp_path / "s.parquet")
    q = table[[f"q{i}_rad" for i in range(1, 7)]].to_numpy()
    # The simulated tracker stands where the plan says: ranges agree within the hidden
    # errors (the simulated arm's true reflector is its own, 0,0,100 and 1.5 mm off).
    nominal = kinematics.forward(
        robots.get("ur10e").mdh, q, frames.transform(translation=(0.0, 0.0, 100.0))
    )[:, :3, 3]
    measured = np.linalg.norm(table[["x_mm", "y_mm", "z_mm"]].to_numpy(), axis=1)
    assert np.max(np.abs(measured - np.linalg.norm(nominal - at, axis=1))) < 10.0
