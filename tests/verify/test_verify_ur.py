"""``verify --robot ur://127.0.0.1``: the real ur-rtde client against the fake controller process.

Run under the machine-wide fake-UR lock (fixed ports).
"""

import json
import subprocess

import numpy as np
import pytest
from cli_process_kit import run_cli
from verify_kit import check_outputs

from drivers.robot.ur.simulator.launcher import FakeUrProcess

UR = ("verify", "--robot", "ur://127.0.0.1", "--cycles", "2", "-q")
UR += ("--speed", "1.0", "--accel", "2.0", "--settle", "0", "-o", "v.json")


@pytest.fixture(scope="module")
def fake():
    with FakeUrProcess(time_scale=50.0, model="ur10e", unlock_delay_s=0.5) as process:
        yield process


def test_verify_through_ur_rtde_asks_first_then_runs_the_cycles(fake, tmp_path):
    refused = run_cli(*UR, cwd=tmp_path, stdin=subprocess.DEVNULL)
    assert refused.returncode == 2 and "pass --yes" in refused.stderr, refused.stderr
    assert not list(tmp_path.iterdir())  # nothing journalled, nothing moved
    done = run_cli(*UR, "--yes", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    doc = check_outputs(tmp_path, "v", 2)
    # The arm ends on P1, commanded by the nominal model's IK.
    joints = [float(v) for v in fake.command("fake joints").split()[2:]]
    np.testing.assert_allclose(joints, doc["test_poses"][0]["q_rad"], atol=1e-9)
    assert doc["robot"].startswith("ur://127.0.0.1")


def test_e_stop_mid_test_then_resume_finishes_it(fake, tmp_path):
    # Move 1 is the lead-in; the 5th move is P2 of cycle 1 (plan row 3).
    assert fake.command("fake estop at movej 5") == "fake: estop at movej 5"
    try:
        stopped = run_cli(*UR, "--yes", cwd=tmp_path)
    finally:
        fake.command("fake estop at movej 0")
    assert stopped.returncode == 1, stopped.stderr
    assert "robot halted at pose 3" in stopped.stderr and "--resume" in stopped.stderr
    journal = tmp_path / "v.json.journal"
    kept = [json.loads(line)["pose"] for line in journal.read_text().splitlines()[1:]]
    assert kept == [0, 1, 2]
    assert not (tmp_path / "v.json").exists()
    fake.command("fake release estop")
    fake.command("power on")
    fake.command("brake release")
    again = run_cli(*UR, "--resume", "--yes", cwd=tmp_path)
    assert again.returncode == 0, again.stderr
    check_outputs(tmp_path, "v", 2)
