"""Running the command line in-process (fast) and checking its one-line errors."""

import os
from contextlib import redirect_stderr, redirect_stdout
from dataclasses import dataclass
from io import StringIO
from pathlib import Path

from calibrator.cli import main


@dataclass
class Outcome:
    code: int
    stdout: str
    stderr: str


def cli(*args, cwd):
    """Run ``calibrator ARGS`` through the console entry point, in ``cwd``."""
    out, err = StringIO(), StringIO()
    before = Path.cwd()
    os.chdir(cwd)
    try:
        with redirect_stdout(out), redirect_stderr(err):
            try:
                main([str(a) for a in args])
                code = 0
            except SystemExit as exc:
                code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    finally:
        os.chdir(before)
    return Outcome(code, out.getvalue(), err.getvalue())


def one_line_error(result):
    """The error line of a refused command: exit 2, one line, no traceback."""
    assert result.code == 2, (result.code, result.stdout, result.stderr)
    assert "Traceback" not in result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("calibrator: error: ")
    return lines[0]


def refused_line(completed):
    """The last stderr line of a command run as a process and refused (exit 2)."""
    assert completed.returncode == 2, (completed.returncode, completed.stderr)
    return completed.stderr.strip().splitlines()[-1]


def listing(folder):
    """Every file and folder under ``folder`` (hidden ones too), with contents."""
    folder = Path(folder)
    return {
        str(p.relative_to(folder)): (p.read_bytes() if p.is_file() else None)
        for p in sorted(folder.rglob("*"))
    }
