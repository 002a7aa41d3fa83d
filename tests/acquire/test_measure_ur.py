"""``measure --robot ur://127.0.0.1``: the real ur-rtde client against the fake controller process.

The fake (a UR10e, moves 50 times faster than real) and the tracker simulator
are separate processes; the tracker's target follows the joints the fake
reports. Noise-free, so the session equals the simulated-robot reference run.
"""

import json
import subprocess

import numpy as np
import pytest
from cli_process_kit import run_cli
from measure_kit import session_rows

from calibrator import cell, planning, robots
from calibrator.simulate import SIM_TRACKER_AT_MM
from drivers.robot.ur.simulator.launcher import FakeUrProcess

UR = ("measure", "--robot", "ur://127.0.0.1", "--poses", "12", "--tracker", "sim://?noise=off")
UR += ("--speed", "1.0", "--accel", "2.0", "-o", "s.parquet")


@pytest.fixture(scope="module")
def fake():
    with FakeUrProcess(time_scale=50.0, model="ur10e", unlock_delay_s=0.5) as process:
        yield process


def made_plan(n):
    """The plan ``measure --poses n`` makes on the simulated cell (vias included)."""
    where = cell.Cell(tracker_at_mm=tuple(float(v) for v in SIM_TRACKER_AT_MM))
    return planning.make_checked(robots.get("ur10e"), n, where, (0.0, 0.0, 100.0), seed=0).plan


def assert_matches_reference(path, reference):
    rows, ref = session_rows(path), session_rows(reference)
    assert sorted(rows) == sorted(ref)
    for pose in ref:
        np.testing.assert_allclose(rows[pose][0], ref[pose][0], atol=1e-9)
        np.testing.assert_allclose(rows[pose][1], ref[pose][1], atol=1e-6)


def test_measure_through_ur_rtde_completes_a_plan(fake, tmp_path, reference_session):
    refused = run_cli(*UR, "--settle", "0", cwd=tmp_path, stdin=subprocess.DEVNULL)
    assert refused.returncode == 2 and "pass --yes" in refused.stderr
    assert not list(tmp_path.iterdir())  # nothing journalled, nothing moved
    done = run_cli(*UR, "--settle", "0", "--yes", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert_matches_reference(tmp_path / "s.parquet", reference_session)
    joints = [float(v) for v in fake.command("fake joints").split()[2:]]
    np.testing.assert_allclose(joints, session_rows(tmp_path / "s.parquet")[11][0], atol=1e-9)


def test_e_stop_then_power_on_brake_release_and_resume(fake, tmp_path, reference_session):
    # Pressed as the move to pose 3 arrives (after the vias before it), and shown late
    # on the RTDE stream: the move is refused before the stream has the stop, which
    # must still read as the e-stop.
    move = 4 + sum(len(v) for v in made_plan(12).via_rad[:4])
    assert fake.command(f"fake estop at movej {move}") == f"fake: estop at movej {move}"
    assert fake.command("fake safety lag 0.3") == "fake: safety lag 0.3"
    try:
        stopped = run_cli(*UR, "--settle", "0.05", "--yes", cwd=tmp_path)
    finally:
        fake.command("fake safety lag 0")
        fake.command("fake estop at movej 0")
    err = stopped.stderr
    assert stopped.returncode == 1, err
    assert "stopped: robot halted at pose 3: emergency stop" in err
    assert "power on and release the brakes" in err and "--resume" in err
    journal = tmp_path / "s.parquet.journal"
    kept = [json.loads(line)["pose"] for line in journal.read_text().splitlines()[1:]]
    assert kept == [0, 1, 2]

    # Still e-stopped, then powered off: resume refuses in one line, nothing moves.
    still = run_cli(*UR, "--resume", "--yes", cwd=tmp_path)
    assert still.returncode == 2 and still.stderr.count("\n") == 1, still.stderr
    fake.command("fake release estop")
    assert fake.command("robotmode") == "Robotmode: POWER_OFF"
    off = run_cli(*UR, "--resume", "--yes", cwd=tmp_path)
    assert off.returncode == 2 and "power the arm on" in off.stderr, off.stderr
    assert fake.command("power on") == "Powering on"
    assert fake.command("brake release") == "Brake releasing"

    again = run_cli(*UR, "--resume", "--yes", "--settle", "0", cwd=tmp_path)
    assert again.returncode == 0, again.stderr
    assert f"(#{len(kept) - 1})" not in again.stderr  # finished poses are not measured again
    assert_matches_reference(tmp_path / "s.parquet", reference_session)
