"""``measure --robot external`` end to end: a simulated controller plays the plan.

Real processes throughout: the tracker simulator on loopback TCP, the
external-robot player steering its target with ``SIM,TARGET`` every 20 ms,
and ``calibrator measure`` reading the tracker over its own connection.
"""

import json

import numpy as np
import pyarrow.parquet as pq
import pytest
from cli_process import run_cli
from external_cell import start_player, tracker_simulator

from calibrator import plan as plans

FAST = ("--speed", "3", "--accel", "6")  # a simulated controller: quicker than the cap


@pytest.fixture(scope="module")
def plan40(tmp_path_factory):
    cwd = tmp_path_factory.mktemp("plan")
    done = run_cli(
        "plan",
        "--poses",
        "40",
        "--tracker-at",
        "2500,400,300",
        "-o",
        "plan.csv",
        "--seed",
        "1",
        cwd=cwd,
    )
    assert done.returncode == 0, done.stderr
    return cwd / "plan.csv"


def test_a_40_pose_program_with_a_skip_and_a_pause_reaches_the_noise_floor(tmp_path, plan40):
    with tracker_simulator(seed=2) as url:
        player = start_player(
            plan40,
            url,
            "--seed",
            "3",
            *FAST,
            "--dwell",
            "1.5",
            "--skip",
            "7",
            "--pause",
            "20:0.5:1.5",
            "--vibration",
            "0.3",
            "--start-delay",
            "1",
            cwd=tmp_path,
        )
        done = run_cli(
            "measure",
            "--robot",
            "external",
            "--plan",
            plan40,
            "--tracker",
            url,
            "-o",
            "s.parquet",
            # Longer than the longest move: a move to a pose may pass through
            # the plan's vias (the arm upright) without stopping.
            "--stop-timeout",
            "15",
            cwd=tmp_path,
            timeout=600,
        )
        assert player.wait(timeout=60) == 0, player.stderr.read()
    assert done.returncode == 0, done.stderr
    # the skipped pose is reported missing under its own number
    assert "missing: 1 pose(s) the program did not stop at: [7]" in done.stdout
    assert "1 pose(s) failed" in done.stdout and "[7]" in done.stdout
    # the pause midway (stop before pose 20) was a stop that matched no pose
    rejected = [line for line in done.stdout.splitlines() if line.startswith("rejected stop")]
    assert any("matches no expected pose" in line for line in rejected), done.stdout

    table = pq.read_table(tmp_path / "s.parquet").to_pydict()
    assert table["pose"] == [p for p in range(40) if p != 7]  # no pose number shifted
    q = np.column_stack([table[f"q{i}_rad"] for i in range(1, 7)])
    np.testing.assert_array_equal(q, np.delete(plans.read_plan(plan40).q_rad, 7, axis=0))
    # each recorded point is where the true arm put the reflector at that pose
    truth_done = run_truth(plan40, tmp_path)
    points = np.column_stack([table[c] for c in ("x_mm", "y_mm", "z_mm")])
    assert np.max(np.linalg.norm(points - np.delete(truth_done, 7, axis=0), axis=1)) < 0.1

    spread = np.column_stack([table[c] for c in ("sx_mm", "sy_mm", "sz_mm")])
    floor = float(np.sqrt(np.mean(np.sum(spread**2, axis=1)) / 10))
    ident = run_cli("identify", "s.parquet", "-o", "cal.json", cwd=tmp_path)
    assert ident.returncode == 0, ident.stderr
    held_out = json.loads((tmp_path / "cal.json").read_text())["stats"]["validation"]
    assert held_out["before"]["position_mm"]["mean"] > 0.3
    assert held_out["after"]["position_mm"]["mean"] < 2.5 * floor


def run_truth(plan_path, cwd):
    """True reflector points (tracker frame, mm) of the player's hidden arm for the plan."""
    from drivers.robot.external_sim.player import Player, PlayerOptions

    q = plans.read_plan(plan_path).q_rad  # the measured poses (vias are only moved through)
    player = Player.for_model(q, "ur10e", 3, PlayerOptions())
    return player.tool_points(q)


def test_a_program_that_ends_early_resumes_with_the_rest(tmp_path):
    done = run_cli(
        "plan",
        "--poses",
        "14",
        "--tracker-at",
        "2500,400,300",
        "-o",
        "plan.csv",
        "--seed",
        "2",
        cwd=tmp_path,
    )
    assert done.returncode == 0, done.stderr
    plan = tmp_path / "plan.csv"
    common = (
        "measure",
        "--robot",
        "external",
        "--plan",
        plan,
        "-o",
        "s.parquet",
        "--stop-timeout",
        "4",
    )
    with tracker_simulator(seed=4) as url:
        # the operator stops the program after pose 8
        first = start_player(
            plan,
            url,
            "--seed",
            "3",
            *FAST,
            "--dwell",
            "1.2",
            "--skip",
            "9,10,11,12,13",
            "--start-delay",
            "1",
            cwd=tmp_path,
        )
        part = run_cli(*common, "--tracker", url, cwd=tmp_path, timeout=300)
        assert first.wait(timeout=60) == 0
        assert part.returncode == 0, part.stderr
        assert "missing: 5 pose(s)" in part.stdout and "[9, 10, 11, 12, 13]" in part.stdout
        assert (tmp_path / "s.parquet.journal").exists()  # kept for --resume
        # restarted from pose 9: resume records the rest under their own numbers
        second = start_player(
            plan,
            url,
            "--seed",
            "3",
            *FAST,
            "--dwell",
            "1.2",
            "--skip",
            "0,1,2,3,4,5,6,7,8",
            "--start-delay",
            "1",
            cwd=tmp_path,
        )
        rest = run_cli(*common, "--tracker", url, "--resume", cwd=tmp_path, timeout=300)
        assert second.wait(timeout=60) == 0
    assert rest.returncode == 0, rest.stderr
    assert "wrote s.parquet: 14 poses" in rest.stdout
    table = pq.read_table(tmp_path / "s.parquet").to_pydict()
    assert table["pose"] == list(range(14))
    truth = run_truth(plan, tmp_path)
    points = np.column_stack([table[c] for c in ("x_mm", "y_mm", "z_mm")])
    assert np.max(np.linalg.norm(points - truth, axis=1)) < 0.1
