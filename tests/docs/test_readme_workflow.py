"""The README's "Workflow" block runs as written, as a user's shell runs it.

The block runs once in an empty folder with ``bash -e`` (each command a
``calibrator`` process of this package, on the simulated cell), then a
second time in the same folder, where the first command refuses to replace
its earlier output (no command replaces one without ``--force``).
"""

import os
import re
import subprocess
import sys
from pathlib import Path

from cli_process_kit import child_env

ROOT = Path(__file__).resolve().parents[2]


def workflow_block():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    section = text[text.index("\n## Workflow\n") :]
    return re.search(r"^```sh\n(.*?)^```", section, re.S | re.M).group(1)


def run_block(folder):
    env = child_env()
    # ``calibrator`` on the PATH is this package's entry point, as in an activated venv.
    env["PATH"] = os.pathsep.join([str(Path(sys.executable).parent), env.get("PATH", "")])
    return subprocess.run(
        ["bash", "-e", "-c", workflow_block()],
        cwd=folder,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
        stdin=subprocess.DEVNULL,
    )


def test_the_workflow_runs_as_written_and_a_second_run_refuses_to_replace(tmp_path):
    first = run_block(tmp_path)
    assert first.returncode == 0, first.stderr[-2000:]
    for name in ("plan.csv", "session.parquet", "calibration.json", "params.csv"):
        assert (tmp_path / name).stat().st_size > 0, name
    assert (tmp_path / "corrected.csv").read_text().count("\n") == 2  # header and one target
    # The program's pose targets are corrected: the filtered program differs from it.
    program = (tmp_path / "cell.script").read_text()
    filtered = (tmp_path / "cell_calibrated.script").read_text()
    poses = program.count("movej(p[")
    assert poses == 60 and filtered != program
    found = re.search(r"^60 pose target\(s\): (\d+) corrected, 0 kept, (\d+) failed$",
                      first.stdout + first.stderr, re.M)  # fmt: skip
    assert found, first.stderr[-2000:]
    corrected, failed = int(found.group(1)), int(found.group(2))
    assert corrected + failed == 60 and corrected >= 55
    # Each corrected target's line differs; a failed one is kept, marked.
    changed = [
        (a, b) for a, b in zip(program.splitlines(), filtered.splitlines(), strict=True) if a != b
    ]
    assert sum("not corrected" not in b for _, b in changed) == corrected
    assert sum("not corrected" in b for _, b in changed) == failed
    assert (tmp_path / "report" / "index.html").is_file()
    before = {p.name: p.stat().st_mtime_ns for p in tmp_path.iterdir()}

    again = run_block(tmp_path)
    assert again.returncode == 2
    assert again.stderr.strip().splitlines()[-1] == (
        "calibrator: error: plan.csv exists: remove it, choose another -o, "
        "or pass --force to replace it"
    )
    assert {p.name: p.stat().st_mtime_ns for p in tmp_path.iterdir()} == before
