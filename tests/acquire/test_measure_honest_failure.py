"""A run that measured nothing says so; a run never takes over another run's files.

- Every reading lost (the beam broken throughout): exit 1, no session file,
  no "wrote" claim, the cause named with its count.
- ``--resume`` of a running job is refused (the journal's lock), and an
  existing session file that the journal's run did not write is never replaced.
- A plan larger than identify accepts is refused before anything moves.
"""

import csv
import subprocess
import sys
import time

import numpy as np
from cli_process_kit import run_cli

from calibrator import robots
from calibrator.acquire.run import MAX_POSES
from calibrator.identify.pipeline import MAX_POSES as IDENTIFY_MAX_POSES
from drivers.tracker.line.simulator import SimulatorProcess

BASE = ("measure", "--poses", "12", "-o", "s.parquet")
FAULTED = "sim://?noise=off&faults=faults.txt"  # the simulated tracker's settings
# The beam broken for every reading (the simulator re-locks when the target moves,
# so each reading gets its own fault).
NEVER = "".join(f"MEAS@{n} beam_break\n" for n in range(1, 400))


def one_line(stderr):
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in stderr, stderr
    return lines[0]


def test_a_run_with_the_beam_broken_throughout_writes_nothing_and_exits_1(tmp_path):
    (tmp_path / "faults.txt").write_text(NEVER)
    done = run_cli(*BASE, "-q", "--retries", "1", "--retry-pause", "0.01",
                   "--tracker", FAULTED, cwd=tmp_path)  # fmt: skip
    assert done.returncode == 1
    assert done.stdout == ""  # no "wrote ..." claim
    line = one_line(done.stderr)
    assert line.startswith("calibrator: error: no pose measured, no session written: ")
    assert "5 poses in a row failed" in line and "5 pose(s) failed: beam broken x10" in line
    assert not (tmp_path / "s.parquet").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["faults.txt", "s.parquet.journal"]


def test_a_line_protocol_tracker_steered_from_outside_with_the_beam_broken(tmp_path):
    """Acceptance S2's shape: a tracker simulator started by hand, found by its device path."""
    (tmp_path / "faults.txt").write_text(NEVER)
    with SimulatorProcess(noise=False, initialised=True, faults=tmp_path / "faults.txt") as sim:
        done = run_cli(*BASE, "-q", "--tracker", sim.url, "--robot", f"sim://?control={sim.control_url}",
                       "--retries", "0", "--retry-pause", "0", cwd=tmp_path)  # fmt: skip
    assert done.returncode == 1 and done.stdout == ""
    line = one_line(done.stderr)
    assert "no pose measured, no session written" in line and "beam broken x5" in line
    assert not (tmp_path / "s.parquet").exists()


def test_the_pause_before_each_retry_is_taken(tmp_path):
    (tmp_path / "faults.txt").write_text(NEVER)
    t0 = time.perf_counter()
    done = run_cli(*BASE, "-q", "--retries", "2", "--retry-pause", "0.2",
                   "--tracker", FAULTED, cwd=tmp_path)  # fmt: skip
    elapsed = time.perf_counter() - t0
    assert done.returncode == 1
    assert elapsed >= 5 * (0.2 + 0.4)  # five poses, two retries each, the pause doubling


def test_a_control_url_is_a_setting_of_the_simulated_robot_only(tmp_path):
    # Only the simulated arm knows where its probe is, so only its URL takes one.
    done = run_cli(*BASE, "--robot", "ur://127.0.0.1?control=socket://127.0.0.1:1",
                   cwd=tmp_path)  # fmt: skip
    assert done.returncode == 2
    assert "ur:// takes no parameters" in one_line(done.stderr)
    assert list(tmp_path.iterdir()) == []


def test_an_unreachable_control_url_is_refused_in_one_line_before_anything_moves(tmp_path):
    done = run_cli(*BASE, "--robot", "sim://?control=socket://127.0.0.1:1", cwd=tmp_path)
    assert done.returncode == 2
    assert one_line(done.stderr).startswith(
        "calibrator: error: --robot: control=socket://127.0.0.1:1: "
    )
    assert list(tmp_path.iterdir()) == []


def test_a_plan_larger_than_identify_takes_is_refused_before_anything_moves(tmp_path):
    assert MAX_POSES == IDENTIFY_MAX_POSES
    limits = robots.get("ur10e").joint_limits_rad
    q = np.random.default_rng(0).uniform(limits[:, 0] / 2, limits[:, 1] / 2, (60_000, 6))
    with open(tmp_path / "big.csv", "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow([f"q{i}_rad" for i in range(1, 7)])
        writer.writerows(q.round(6).tolist())
    done = run_cli(*BASE, "--plan", "big.csv", cwd=tmp_path)
    assert done.returncode == 2
    assert one_line(done.stderr) == (
        "calibrator: error: plan has 60000 poses; identify takes at most 50000: thin the plan "
        "(a well-spread subset identifies as well)"
    )
    assert sorted(p.name for p in tmp_path.iterdir()) == ["big.csv"]


def test_resume_never_replaces_a_session_file_its_run_did_not_write(tmp_path, pose_3_failed):
    first = pose_3_failed
    assert first.returncode == 0 and "failed" in first.stdout  # journal kept, session written
    other = tmp_path / "other"
    other.mkdir()
    assert run_cli(*BASE, "--seed", "5", cwd=other).returncode == 0
    (tmp_path / "s.parquet").write_bytes((other / "s.parquet").read_bytes())  # someone else's
    before = (tmp_path / "s.parquet").read_bytes()
    refused = run_cli(*BASE, "--resume", cwd=tmp_path)
    assert refused.returncode == 2
    assert one_line(refused.stderr) == (
        "calibrator: error: s.parquet exists and was not written by the run in "
        "s.parquet.journal: move it away, then resume"
    )
    assert (tmp_path / "s.parquet").read_bytes() == before
    (tmp_path / "s.parquet").unlink()  # moved away: the run resumes
    assert run_cli(*BASE, "--resume", cwd=tmp_path).returncode == 0


def test_a_second_resume_of_a_running_job_is_refused(tmp_path):
    # 1 s of settling a pose: the first run lasts about 12 s, long enough for a
    # second process to start on a loaded machine (with 0.3 s it sometimes ended first).
    proc = subprocess.Popen(
        [sys.executable, "-m", "calibrator", *BASE, "-q", "--settle", "1.0"],
        cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        path = tmp_path / "s.parquet.journal"
        deadline = time.monotonic() + 30
        while not (path.exists() and path.read_text().count("\n") >= 2):
            assert time.monotonic() < deadline and proc.poll() is None, proc.communicate(timeout=30)
            time.sleep(0.02)
        second = run_cli(*BASE, "--resume", cwd=tmp_path)
        assert second.returncode == 2
        assert one_line(second.stderr) == (
            "calibrator: error: s.parquet.journal is in use by another measure run: wait for it "
            "to end (or stop it), then resume"
        )
        assert proc.poll() is None  # the first run goes on, alone
    finally:
        out, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    assert out.startswith("wrote s.parquet: 12 poses")
