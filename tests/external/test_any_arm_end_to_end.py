"""A KUKA arm end to end, as an integrator runs it: plan, program, measure, identify.

Real processes throughout. The plan is made for the shipped KR 6 R900
description; the KRL and RAPID programs written from it are read back and
turned into the description's angles through its joint convention (KUKA's
A1 and A6 turn the other way); the joints read back from the KRL program
are what the external-robot simulator plays, on a perturbed copy of the arm
(its hidden errors, tool and tracker placement); ``measure --robot external``
only watches the tracker; ``identify`` must come within 1.5x of least
squares started from the truth.
"""

import json

import numpy as np
import pyarrow.parquet as pq
from cli_process_kit import run_cli
from external_cell_kit import Watching, press_start, start_player, tracker_simulator
from grammar_kit import PARSERS
from truth_kit import against_least_squares_from_truth

from calibrator import planning, robots
from calibrator.model import kinematics

ARM = "kuka-kr6-r900"
SKIPPED = 5
DWELL = 3.0  # controller seconds (both simulators at external_cell_kit.TIME_SCALE)


def _read_back(program_text: str, fmt: str, plan: planning.Plan) -> planning.Plan:
    """The program's targets in the description's angles, as a plan (home moves dropped)."""
    ctrl = np.array(PARSERS[fmt](program_text).targets())[1:-1]
    path = robots.get(ARM).convention.to_model(ctrl)
    rows, vias, i = [], [], 0
    for via in plan.via_rad:
        vias.append(path[i : i + len(via)])
        rows.append(path[i + len(via)])
        i += len(via) + 1
    assert i == len(path)
    return planning.Plan(np.array(rows), tuple(vias))


def test_a_kuka_is_planned_programmed_measured_and_identified_as_from_the_truth(tmp_path):
    made = run_cli(
        "plan", "--model", ARM, "--poses", "16", "--tracker-at", "2500,400,300",
        "-o", "plan.csv", "--seed", "2", cwd=tmp_path,
    )  # fmt: skip
    assert made.returncode == 0, made.stderr
    plan = planning.read_plan(tmp_path / "plan.csv")
    for name, fmt in (("cal.src", "krl"), ("cal.mod", "rapid")):
        done = run_cli("program", "plan.csv", "--model", ARM, "-o", name, cwd=tmp_path)
        assert done.returncode == 0, done.stderr
        back = _read_back((tmp_path / name).read_text(), fmt, plan)
        # 1e-6 deg written: the read-back plan is the plan to 1e-8 rad
        np.testing.assert_allclose(back.path_rad, plan.path_rad, rtol=0, atol=2e-8)
    # What the controller runs: the KRL program's joints, back in the description's angles.
    played = _read_back((tmp_path / "cal.src").read_text(), "krl", plan)
    # The played plan holds what the controller runs: its own angles.
    planning.write_plan(tmp_path / "played.csv", played, arm=robots.get(ARM))

    with tracker_simulator(seed=2) as url:
        player = start_player(
            tmp_path / "played.csv", url, "--model", ARM, "--seed", 3, "--speed", "3",
            "--accel", "6", "--dwell", DWELL, "--skip", SKIPPED,
            "--truth", "truth.json", cwd=tmp_path,
        )  # fmt: skip
        run = Watching(
            "--model", ARM, "--plan", "plan.csv", "--tracker", url, "-o", "s.parquet",
            "--stop-timeout", "15", cwd=tmp_path,
        )  # fmt: skip
        press_start(player)
        done = run.result(timeout=600)
        assert player.wait(timeout=60) == 0, player.stderr.read()
    assert done.returncode == 0, done.stderr
    assert f"did not stop at: [{SKIPPED}]" in done.stdout, done.stdout
    table = pq.read_table(tmp_path / "s.parquet").to_pydict()
    assert table["pose"] == [p for p in range(len(plan.q_rad)) if p != SKIPPED]

    ident = run_cli("identify", "s.parquet", "-o", "cal.json", cwd=tmp_path)
    assert ident.returncode == 0, ident.stderr
    truth_doc = json.loads((tmp_path / "truth.json").read_text())
    truth = tuple(np.array(truth_doc[k]) for k in ("true_mdh", "flange2tool", "base2tracker"))
    true_points = kinematics.forward(truth[0], plan.q_rad, truth[1], truth[2])[:, :3, 3]
    figures = against_least_squares_from_truth(tmp_path, truth, plan.q_rad, true_points)
    print(figures)  # pytest -s shows the figure
    assert figures["rms_ratio"] <= 1.5, figures
    assert figures["prediction_ratio"] <= 1.5, figures
