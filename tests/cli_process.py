"""Running ``calibrator`` as a user does: a new process, its output and exit code."""

import subprocess
import sys


def run_cli(*args, cwd=None, timeout=120, **kwargs):
    """``python -m calibrator ARGS`` in ``cwd``; the completed process (text output)."""
    return subprocess.run(
        [sys.executable, "-m", "calibrator", *map(str, args)],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=timeout,
        **kwargs,
    )
