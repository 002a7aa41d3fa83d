"""``check --robot external``: its plan and program written; an unseen controller plays them.

Real processes: the tracker simulator on loopback TCP, the external-robot
player (its hidden arm crashed by a world file) steering the target, and
``calibrator check`` watching the tracker.
"""

import json
import sys
import time
from pathlib import Path

from cli_process_kit import run_cli

sys.path.insert(0, str(Path(__file__).parents[1] / "external"))
from external_cell_kit import Watching, press_start, start_player, tracker_simulator  # noqa: E402

CRASH = "world: 1\nmodel: ur10e\njoint_zero_shifts_rad: [0, 0, 4.0e-4, 0, 0, 0]\n"


def test_an_external_robots_crash_is_found_from_the_checks_own_program(tmp_path):
    # The calibration of the player's hidden arm (seed 3), measured on the simulated cell.
    done = run_cli(
        "measure", "--model", "ur10e", "--seed", "3", "--poses", "30", "-o", "cal.parquet", "-q",
        cwd=tmp_path,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    done = run_cli("identify", "cal.parquet", "-o", "cal.json", "-q", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    (tmp_path / "crash.yaml").write_text(CRASH)
    with tracker_simulator(seed=2) as url:
        check = Watching(
            "--model", "ur10e", "--calibration", "cal.json", "--tracker", url, "-o", "check.json",
            cwd=tmp_path, command="check", wait=False,
        )  # fmt: skip
        # The check writes its plan and program first, then opens the devices: the
        # controller loads the program meanwhile, and starts it once the check watches.
        plan = tmp_path / "check.plan.csv"
        deadline = time.monotonic() + 120
        while not plan.exists():
            assert check.proc.poll() is None and time.monotonic() < deadline, check.result(0)
            time.sleep(0.02)
        player = start_player(
            plan, url, "--seed", 3, "--world", "crash.yaml", "--speed", "3", "--accel", "6",
            "--dwell", 3, cwd=tmp_path,
        )  # fmt: skip
        check.wait_ready()
        assert (tmp_path / "check.program.csv").exists()
        press_start(player)
        result = check.result(timeout=300)
        assert player.wait(timeout=60) == 0, player.stderr.read()
    assert result.returncode == 4, result.stderr
    doc = json.loads((tmp_path / "check.json").read_text())
    assert doc["verdict"] == "recalibrate" and len(doc["poses"]) == 8
    assert doc["explanation"][0]["causes"] == ["joint 3 zero"], doc["explanation_text"]
    # The crash shifted joint 3's zero by 0.4 mrad: found within its standard error.
    change = doc["explanation"][0]["parameters"][0]
    assert abs(change["change"] - 0.4e-3) < 5 * change["standard_error"] + 2e-5, change
    assert doc["explanation_text"][0].startswith("joint 3 zero moved +0.")
