"""Every fenced Python example in README.md and docs/*.md runs as written.

Each block runs on its own, in a new interpreter and an empty folder, so it
must carry its own imports. A block whose first line is ``# requires
hardware`` is only compiled.
"""

import re
import subprocess
import sys
from pathlib import Path

import pytest
from cli_process_kit import child_env

ROOT = Path(__file__).resolve().parents[2]
FENCE = re.compile(r"^```python[^\n]*\n(.*?)^```", re.S | re.M)
HARDWARE = "# requires hardware"


def examples():
    """``(id, code)`` of every fenced Python block, in file order."""
    found = []
    for doc in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        text = doc.read_text(encoding="utf-8")
        for match in FENCE.finditer(text):
            line = text.count("\n", 0, match.start()) + 1
            found.append(pytest.param(match.group(1), id=f"{doc.relative_to(ROOT)}:{line}"))
    return found


def test_the_docs_have_examples():
    assert len(examples()) >= 5


@pytest.mark.parametrize("code", examples())
def test_example_runs_as_written(code, tmp_path):
    if code.lstrip().startswith(HARDWARE):
        compile(code, "<example>", "exec")
        return
    done = subprocess.run(
        [sys.executable, "-c", code],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
        env=child_env(None),
    )
    assert done.returncode == 0, done.stderr[-3000:]
