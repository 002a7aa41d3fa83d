"""``calibrator analyze`` run as a user runs it (a real process), for the analysis tests."""

import json
from pathlib import Path

from cli_process_kit import run_cli


def analyze(*args, cwd):
    """``calibrator analyze ARGS`` as a process in ``cwd``."""
    return run_cli("analyze", *args, cwd=cwd)


def analyze_json(*args, cwd):
    """``analyze ARGS`` with ``--json FILE``, which must succeed: the process, FILE's document."""
    out = analyze(*args, cwd=cwd)
    assert out.returncode == 0, out.stderr
    name = args[args.index("--json") + 1]
    return out, json.loads((Path(cwd) / name).read_text())
