"""``measure --robot external`` end to end: a simulated controller plays the plan.

Real processes throughout: the tracker simulator on loopback TCP, the
external-robot player steering its target with ``SIM,TARGET`` every 20 ms,
and ``calibrator measure`` reading the tracker over its own connection.

The controller runs its program five times faster than real time
(``--time-scale``): moves, dwells, pauses and ringing alike. The run watches
with a settle window to match (``--settle-window``, as an operator sets it for
a program with short dwells); everything else is as in a cell.
"""

import json

import numpy as np
import pyarrow.parquet as pq
import pytest
from cli_process import run_cli
from external_cell import Watching, start_player, tracker_simulator

from calibrator import plan as plans

SCALE = 5  # controller seconds per wall-clock second
FAST = ("--speed", "3", "--accel", "6", "--time-scale", SCALE)  # quicker than the cap, too
# A dwell (and a pause) of 3.5 s of controller time is 0.7 s of the run's: a settle
# window of 0.3 s leaves time for the ringing to die and the readings to be taken.
DWELL = 3.5
WINDOW = ("--settle-window", "0.3")


def _play(plan, url, cwd, *args):
    """The simulated controller (hidden arm seed 3) runs ``plan`` on the tracker at ``url``."""
    return start_player(plan, url, "--seed", 3, *FAST, "--dwell", DWELL, *args, cwd=cwd)


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
        measure = Watching(
            "--plan", plan40, "--tracker", url, "-o", "s.parquet", *WINDOW,
            # Longer than the longest move: a move to a pose may pass through
            # the plan's vias (the arm upright) without stopping.
            "--stop-timeout", "15",
            cwd=tmp_path,
        )  # fmt: skip
        player = _play(
            plan40, url, tmp_path, "--skip", "7", "--pause", f"20:0.5:{DWELL}",
            "--vibration", "0.3", "--start-delay", "1",
        )  # fmt: skip
        done = measure.result(timeout=600)
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
    common = ("--plan", plan, "-o", "s.parquet", *WINDOW, "--stop-timeout", "4")
    with tracker_simulator(seed=4) as url:
        # the operator stops the program after pose 8
        run = Watching(*common, "--tracker", url, cwd=tmp_path)
        first = _play(plan, url, tmp_path, "--skip", "9,10,11,12,13", "--start-delay", "1")
        part = run.result(timeout=300)
        assert first.wait(timeout=60) == 0
        assert part.returncode == 0, part.stderr
        assert "missing: 5 pose(s)" in part.stdout and "[9, 10, 11, 12, 13]" in part.stdout
        assert (tmp_path / "s.parquet.journal").exists()  # kept for --resume
        # restarted from pose 9: resume records the rest under their own numbers
        run = Watching(*common, "--tracker", url, "--resume", cwd=tmp_path)
        second = _play(plan, url, tmp_path, "--skip", "0,1,2,3,4,5,6,7,8", "--start-delay", "1")
        rest = run.result(timeout=300)
        assert second.wait(timeout=60) == 0
    assert rest.returncode == 0, rest.stderr
    assert "wrote s.parquet: 14 poses" in rest.stdout
    table = pq.read_table(tmp_path / "s.parquet").to_pydict()
    assert table["pose"] == list(range(14))
    truth = run_truth(plan, tmp_path)
    points = np.column_stack([table[c] for c in ("x_mm", "y_mm", "z_mm")])
    assert np.max(np.linalg.norm(points - truth, axis=1)) < 0.1
