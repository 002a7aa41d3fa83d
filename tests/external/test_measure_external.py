"""``measure --robot external`` end to end: a simulated controller plays the plan.

Real processes throughout: the tracker simulator on loopback TCP, the
external-robot player steering its target with ``SIM,TARGET`` every 20 ms,
and ``calibrator measure`` reading the tracker over its own connection.

Both simulators run ten times faster than real time (external_cell_kit.py): the
controller's moves, dwells, pauses and ringing, and the tracker's clock. The
run's options are a cell's (a settle window of 0.5 s of the tracker's clock);
only the wall clock is shorter. The plan is
the session's shared one (conftest.py), made for a reflector 14 mm from the
default guess the runs measure with; the controller's reflector is there.
"""

import json
import re

import numpy as np
import pyarrow.parquet as pq
from cli_process_kit import run_cli
from external_cell_kit import (
    TOOL_MM,
    Watching,
    first_poses,
    press_start,
    start_player,
    tracker_simulator,
)

from calibrator import planning

FAST = ("--speed", "3", "--accel", "6")  # quicker than the cap, too
# A dwell (and a pause) of 3 s leaves the ringing time to die, the 0.5 s settle window
# and the readings time to be taken, and a loaded host (0.3 s on the wall clock) time
# to be late.
DWELL = 3.0


def _play(plan, url, cwd, *args):
    """The simulated controller (hidden arm seed 3) runs ``plan`` on the tracker at ``url``."""
    tool = ",".join(map(str, TOOL_MM))
    return start_player(
        plan, url, "--seed", 3, "--tool", tool, *FAST, "--dwell", DWELL, *args, cwd=cwd
    )


def test_a_40_pose_program_with_a_skip_a_pause_and_wrong_stops_reaches_the_noise_floor(
    tmp_path, plan40
):
    """Pose 7 skipped, a pause on the way to 20, ringing, and the controller stopping
    9.8 mm from where poses 1 and 25 belong (a wrong point in its program): with
    ``-q`` too, the wrong stops are rejected and named in the summary, their poses
    missing, and the other 37 poses recorded under their own numbers."""
    plan40 = first_poses(plan40, 40, tmp_path / "plan.csv")  # measured with the default guess
    wrong = _moved(plan40, tmp_path / "played.csv", {1: 9.8, 25: 9.8})
    with tracker_simulator(seed=2) as url:
        player = _play(
            wrong, url, tmp_path, "--skip", "7", "--pause", f"20:0.5:{DWELL}",
            "--vibration", "0.3", "--start-delay", "1",
        )  # fmt: skip
        measure = Watching(
            "--plan", plan40, "--tracker", url, "-o", "s.parquet",
            # Longer than the longest move: a move to a pose may pass through
            # the plan's vias (the arm upright) without stopping.
            "--stop-timeout", "15", "-q",
            cwd=tmp_path,
        )  # fmt: skip
        press_start(player)  # the operator starts the loaded program once the run watches
        done = measure.result(timeout=600)
        assert player.wait(timeout=60) == 0, player.stderr.read()
    assert done.returncode == 0, done.stderr
    assert not [line for line in done.stderr.splitlines() if line.startswith("stop ")]  # -q
    # the skipped pose and the two stopped wrongly at are missing under their own numbers
    missed = [1, 7, 25]
    assert f"missing: 3 pose(s) the program did not stop at: {missed}" in done.stdout, done.stdout
    assert "3 pose(s) failed" in done.stdout and str(missed) in done.stdout
    assert "retries" not in done.stdout  # the program passes each pose once: nothing retried
    rejected = [line for line in done.stdout.splitlines() if line.startswith("rejected stop")]
    # the pause midway (stop before pose 20) was a stop that matched no pose
    others = [line for line in rejected if not re.search(r"nearest is pose (1|25) at", line)]
    assert any("matches no expected pose" in line for line in others), done.stdout
    for pose in (1, 25):  # each wrong stop named: its pose, how far, the tolerance it missed
        named = [line for line in rejected if f"nearest is pose {pose} at" in line]
        assert len(named) == 1, done.stdout
        off = float(named[0].split(f"nearest is pose {pose} at ")[1].split(" mm")[0])
        tolerance = float(named[0].split("(tolerance ")[1].split(" mm")[0])
        assert tolerance < off and 7.0 < off < 13.0, named

    table = pq.read_table(tmp_path / "s.parquet").to_pydict()
    kept = [p for p in range(40) if p not in missed]
    assert table["pose"] == kept  # no pose number shifted
    q = np.column_stack([table[f"q{i}_rad"] for i in range(1, 7)])
    np.testing.assert_array_equal(q, planning.read_plan(plan40).q_rad[kept])
    # each recorded point is where the true arm put the reflector at that pose
    truth_done = run_truth(plan40, tmp_path)
    points = np.column_stack([table[c] for c in ("x_mm", "y_mm", "z_mm")])
    assert np.max(np.linalg.norm(points - truth_done[kept], axis=1)) < 0.1

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

    q = planning.read_plan(plan_path).q_rad  # the measured poses (vias are only moved through)
    player = Player.for_model(q, "ur10e", 3, PlayerOptions(), tool_mm=TOOL_MM)
    return player.tool_points(q)


def test_a_program_that_ends_early_resumes_with_the_rest(tmp_path, plan40):
    plan = first_poses(plan40, 14, tmp_path / "plan.csv")
    # The stop timeout above the longest move plus a dwell, as in a cell; once the
    # program has ended, the poses it did not reach are missing after that long.
    common = ("--plan", plan, "-o", "s.parquet", "--stop-timeout", "15")
    with tracker_simulator(seed=4) as url:
        # the operator stops the program after pose 8
        first = _play(plan, url, tmp_path, "--skip", "9,10,11,12,13", "--start-delay", "1")
        run = Watching(*common, "--tracker", url, cwd=tmp_path)
        press_start(first)
        part = run.result(timeout=300)
        assert first.wait(timeout=60) == 0
        assert part.returncode == 0, part.stderr
        assert "missing: 5 pose(s)" in part.stdout and "[9, 10, 11, 12, 13]" in part.stdout
        assert (tmp_path / "s.parquet.journal").exists()  # kept for --resume
        # restarted from pose 9: resume records the rest under their own numbers
        second = _play(plan, url, tmp_path, "--skip", "0,1,2,3,4,5,6,7,8", "--start-delay", "1")
        run = Watching(*common, "--tracker", url, "--resume", cwd=tmp_path)
        press_start(second)
        rest = run.result(timeout=300)
        assert second.wait(timeout=60) == 0
    assert rest.returncode == 0, rest.stderr
    assert "wrote s.parquet: 14 poses" in rest.stdout
    table = pq.read_table(tmp_path / "s.parquet").to_pydict()
    assert table["pose"] == list(range(14))
    truth = run_truth(plan, tmp_path)
    points = np.column_stack([table[c] for c in ("x_mm", "y_mm", "z_mm")])
    assert np.max(np.linalg.norm(points - truth, axis=1)) < 0.1


def _moved(plan_path, out_path, shifts_mm):
    """A copy of the plan: poses {pose: mm} put the reflector that far off (turning joint 1)."""
    from calibrator import robots
    from calibrator.model import frames, kinematics

    plan = planning.read_plan(plan_path)
    q = plan.q_rad.copy()
    tool = frames.transform(translation=[0.0, 0.0, 100.0])
    points = kinematics.forward(robots.get("ur10e").mdh, q, tool)[:, :3, 3]
    for pose, mm in shifts_mm.items():
        radius = float(np.hypot(*points[pose, :2]))  # the reflector's distance from joint 1's axis
        q[pose, 0] += 2.0 * np.arcsin(mm / (2.0 * radius))
    planning.write_plan(out_path, planning.Plan(q, plan.via_rad))
    return out_path
