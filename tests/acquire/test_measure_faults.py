"""The fault matrix, through the CLI with a scripted tracker simulator.

Every run is noise-free, so a faulted (and resumed) run must equal the
uninterrupted reference run pose for pose, bit for bit: no finished pose is
lost and no row holds a partial average. The 12-pose plan takes 120 MEAS
commands, ten per pose; ``MEAS@25`` is the 5th reading of the 3rd pose.
"""

import json
import os
import signal
import subprocess
import sys
import time

import pytest
from cli_process_kit import run_cli
from measure_kit import assert_same_session, session_rows

BASE = ("measure", "--poses", "12", "--tracker", "sim://?noise=off", "-o", "s.parquet")

#: The noise-free simulated tracker reading the fault script (the last --tracker wins).
FAULTED = "sim://?noise=off&faults=faults.txt"


def faulted_run(tmp_path, script, *extra):
    (tmp_path / "faults.txt").write_text(script + "\n")
    return run_cli(*BASE, "--tracker", FAULTED, *extra, cwd=tmp_path)


def journal(tmp_path):
    lines = (tmp_path / "s.parquet.journal").read_text().splitlines()
    return json.loads(lines[0]), [json.loads(line) for line in lines[1:]]


@pytest.mark.parametrize(
    "script",
    [
        "MEAS@25 beam_break count=2",  # beam breaks mid-average, twice
        "MEAS@37 garble",  # a garbled reply line
        "MEAS@37 bad_crc",
        "MEAS@52 drop",  # no reply: the driver's MEAS timeout
        "MEAS@61 unstable count=6",  # too few stable readings left in the set
    ],
    ids=["beam_break", "garble", "bad_crc", "timeout", "unstable"],
)
def test_lost_readings_remeasure_the_pose(tmp_path, reference_session, script):
    done = faulted_run(tmp_path, script)
    assert done.returncode == 0, done.stderr
    assert_same_session(tmp_path / "s.parquet", reference_session)


def test_pose_fails_after_bounded_retries_and_the_run_goes_on(
    tmp_path, reference_session, pose_3_failed
):
    done = pose_3_failed  # "MEAS@31 beam_break count=40" with --retries 2
    assert done.returncode == 0, done.stderr
    assert "1 pose(s) failed: beam broken x3 (after 2 retries: poses [3])" in done.stdout
    rows, ref = session_rows(tmp_path / "s.parquet"), session_rows(reference_session)
    assert sorted(rows) == [p for p in range(12) if p != 3]
    _, records = journal(tmp_path)
    assert [r["pose"] for r in records if r["status"] == "failed"] == [3]
    # --resume retries only the failed pose; the session is then the reference.
    again = run_cli(*BASE, "--resume", cwd=tmp_path)
    assert again.returncode == 0, again.stderr
    assert_same_session(tmp_path / "s.parquet", reference_session)
    assert len(ref) == 12


def test_resume_refuses_a_journal_of_another_run(tmp_path, pose_3_failed):
    done = pose_3_failed
    assert done.returncode == 0 and "failed" in done.stdout  # the journal stays for --resume
    before = (tmp_path / "s.parquet.journal").read_bytes()
    for extra, what in (
        (("--seed", "1"), "plan_sha256"),  # another plan (and simulated robot)
        (("--readings", "5"), "readings"),
    ):
        refused = run_cli(*BASE, "--resume", *extra, cwd=tmp_path)
        assert refused.returncode == 2, refused.stderr
        assert "belongs to another run" in refused.stderr and what in refused.stderr
        assert refused.stderr.count("\n") == 1
    assert (tmp_path / "s.parquet.journal").read_bytes() == before
    fresh = run_cli(*BASE, cwd=tmp_path)  # without --resume an unfinished run is not replaced
    assert fresh.returncode == 2 and "--resume" in fresh.stderr


def _children(pid):
    out = []
    for task in os.listdir(f"/proc/{pid}/task"):
        with open(f"/proc/{pid}/task/{task}/children") as fh:
            out += [int(c) for c in fh.read().split()]
    return out


def _alive(pid):
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().split(")")[-1].split()[0] != "Z"
    except FileNotFoundError:
        return False


def _start_slow_run(tmp_path):
    return subprocess.Popen(
        [sys.executable, "-m", "calibrator", *BASE, "--settle", "0.15"],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _wait_for_poses(tmp_path, n, proc, timeout=30.0):
    path = tmp_path / "s.parquet.journal"
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if path.exists() and path.read_text().count("\n") >= n + 1:
            return
        assert proc.poll() is None, proc.communicate(timeout=30)
        time.sleep(0.02)
    raise AssertionError(f"fewer than {n} poses journalled in {timeout} s")


def test_sigkill_loses_at_most_the_pose_in_progress_and_resume_completes(
    tmp_path, reference_session
):
    proc = _start_slow_run(tmp_path)
    try:
        _wait_for_poses(tmp_path, 4, proc)
        children = _children(proc.pid)
        assert children, "the tracker simulator runs as a child process"
        proc.kill()
        proc.wait(10)
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.communicate(timeout=30)
    # The simulator notices its parent is gone and exits on its own.
    deadline = time.monotonic() + 5
    while any(_alive(c) for c in children) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not any(_alive(c) for c in children)
    _, records = journal(tmp_path)
    assert len(records) >= 4 and all(r["status"] == "measured" for r in records)
    assert [r["pose"] for r in records] == list(range(len(records)))
    again = run_cli(*BASE, "--resume", cwd=tmp_path)
    assert again.returncode == 0, again.stderr
    first = next(line for line in again.stderr.splitlines() if line.startswith("progress "))
    assert f"done={len(records) + 1} total=12 unit=poses" in first
    assert f" pose={len(records)} " in first  # resumed at the first unfinished plan row
    assert_same_session(tmp_path / "s.parquet", reference_session)


def test_tracker_lost_for_good_ends_run_cleanly_then_resume(tmp_path, reference_session):
    # The tracker (simulator) dies mid-run: the driver's reconnects fail, the run stops.
    proc = _start_slow_run(tmp_path)
    try:
        _wait_for_poses(tmp_path, 4, proc)
        for child in _children(proc.pid):
            os.kill(child, signal.SIGKILL)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 1, err
    assert "stopped: tracker unavailable at pose" in err and "--resume" in err
    assert "Traceback" not in err
    _, records = journal(tmp_path)
    assert len(records) >= 4 and all(r["status"] == "measured" for r in records)
    assert sorted(session_rows(tmp_path / "s.parquet")) == [r["pose"] for r in records]
    # The tracker is back (a new simulator): resume measures only the rest.
    again = run_cli(*BASE, "--resume", cwd=tmp_path)
    assert again.returncode == 0, again.stderr
    first = next(line for line in again.stderr.splitlines() if line.startswith("progress "))
    assert f"done={len(records) + 1} total=12 unit=poses" in first
    assert f" pose={len(records)} " in first  # resumed at the first unfinished plan row
    assert_same_session(tmp_path / "s.parquet", reference_session)
    assert not (tmp_path / "s.parquet.journal").exists()


def test_sigint_stops_after_the_current_pose(tmp_path, reference_session):
    proc = _start_slow_run(tmp_path)
    try:
        _wait_for_poses(tmp_path, 2, proc)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 1
    assert "stopped: interrupted before pose" in err and "Traceback" not in err
    _, records = journal(tmp_path)
    assert 2 <= len(records) < 12
    assert sorted(session_rows(tmp_path / "s.parquet")) == [r["pose"] for r in records]
    again = run_cli(*BASE, "--resume", cwd=tmp_path)
    assert again.returncode == 0, again.stderr
    assert_same_session(tmp_path / "s.parquet", reference_session)
