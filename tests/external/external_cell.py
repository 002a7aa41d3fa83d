"""A cell without a robot link: a tracker simulator on TCP and the external-robot player."""

from __future__ import annotations

import subprocess
import sys
from contextlib import contextmanager
from pathlib import Path

from cli_process import child_env


@contextmanager
def tracker_simulator(seed: int = 2):
    """``python -m drivers.tracker.simulator --tcp 0 --initialised``; yields its socket URL."""
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "drivers.tracker.simulator",
            "--tcp",
            "0",
            "--initialised",
            "--seed",
            str(seed),
        ],
        stdout=subprocess.PIPE,
        text=True,
        env=child_env(None),
    )
    try:
        port = proc.stdout.readline().strip()
        assert port.isdigit(), port
        yield f"socket://127.0.0.1:{port}"
    finally:
        proc.terminate()
        proc.wait(timeout=10)
        proc.stdout.close()


def start_player(plan: Path, url: str, *args, cwd: Path) -> subprocess.Popen:
    """``python -m drivers.robot.external_sim`` playing ``plan`` on the simulator at ``url``."""
    return subprocess.Popen(
        [
            sys.executable,
            "-m",
            "drivers.robot.external_sim",
            "--plan",
            str(plan),
            "--control",
            url,
            *map(str, args),
        ],
        cwd=cwd,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=child_env(None),
    )
