"""A terminal's Ctrl-C reaches the whole foreground process group: measure and
verify still stop after the pose in hand (exit 1, journal kept), because the
simulators they start are in sessions of their own and keep answering."""

import os
import signal
import time

import pytest
from cli_process_kit import start_cli

CASES = [
    ("measure", "--poses", "30", "--settle", "0.1", "-o", "s.parquet"),
    ("verify", "--cycles", "4", "--settle", "0.1", "-o", "v.json"),
]


@pytest.mark.parametrize("args", CASES, ids=["measure", "verify"])
def test_ctrl_c_to_the_process_group_stops_after_the_pose_in_hand(tmp_path, args):
    proc = start_cli(*args, cwd=tmp_path, own_group=True)
    journal = tmp_path / f"{args[-1]}.journal"
    try:
        deadline = time.monotonic() + 90
        while time.monotonic() < deadline and proc.poll() is None:
            if journal.exists() and len(journal.read_text().splitlines()) >= 4:
                break
            time.sleep(0.05)
        assert proc.poll() is None, "the run ended before it could be interrupted"
        os.killpg(proc.pid, signal.SIGINT)  # what a terminal does on Ctrl-C
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait(10)
    last = err.strip().splitlines()[-1]
    assert proc.returncode == 1, err[-2000:]
    assert last.startswith("stopped: interrupted before pose"), last
    assert "tracker unavailable" not in err and "Traceback" not in err
    assert journal.exists()
