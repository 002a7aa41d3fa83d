"""Examples in the docs that a test runs: the commands run, the printed lines are what they print.

A doc marks an example with an HTML comment ``<!-- executed: NAME -->``; the
fenced blocks after it, up to the next blank-line-separated paragraph that
is not a block, belong to it:

- a ``yaml`` block whose first line is ``# FILE`` is written to ``FILE``;
- a ``sh`` block holds commands (``calibrator ...``, continued with ``\\``),
  each followed by the lines it prints, as comments ``#   LINE``; ``...``
  in a printed line stands for any text (times, paths).

:func:`run` runs the commands in-process in a folder and checks every
printed line appears, in order, in the command's output.
"""

from __future__ import annotations

import re
import shlex
from dataclasses import dataclass, field
from pathlib import Path

from cli_kit import cli

ROOT = Path(__file__).resolve().parents[1]
_BLOCK = re.compile(r"^```(\w+)\n(.*?)^```", re.S | re.M)


@dataclass
class Step:
    """One command of an example and the lines it prints."""

    args: list[str]
    printed: list[str] = field(default_factory=list)


def example(doc: str, name: str) -> tuple[dict[str, str], list[Step]]:
    """The files and steps of the example ``name`` in ``docs/DOC``."""
    text = (ROOT / "docs" / doc).read_text(encoding="utf-8")
    marker = f"<!-- executed: {name} -->"
    start = text.index(marker) + len(marker)
    end = text.find("<!-- end executed -->", start)
    assert end > 0, f"{doc}: {marker} has no <!-- end executed -->"
    files: dict[str, str] = {}
    steps: list[Step] = []
    for kind, body in _BLOCK.findall(text[start:end]):
        if kind == "yaml":
            first, _, rest = body.partition("\n")
            files[first.removeprefix("# ").strip()] = rest
        elif kind == "sh":
            steps += _steps(body)
    return files, steps


def _steps(body: str) -> list[Step]:
    steps: list[Step] = []
    pending = ""
    for line in body.splitlines():
        if line.startswith("#   "):
            steps[-1].printed.append(line[4:])
            continue
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        pending += line.rstrip("\\").strip() + " "
        if not line.endswith("\\"):
            args = shlex.split(pending)
            assert args[0] == "calibrator", args
            steps.append(Step(args[1:]))
            pending = ""
    return steps


def _pattern(printed: str) -> re.Pattern:
    return re.compile(".*".join(re.escape(part) for part in printed.split("...")))


def run(doc: str, name: str, folder: Path) -> list:
    """Run the example in ``folder``; assert each printed line. Returns the outcomes."""
    files, steps = example(doc, name)
    for file, content in files.items():
        (folder / file).write_text(content)
    outcomes = []
    for step in steps:
        done = cli(*step.args, cwd=folder)
        assert done.code in (0, 3, 4), (step.args, done.stderr)
        lines = done.stdout.splitlines()
        at = 0
        for printed in step.printed:
            pattern = _pattern(printed.strip())
            while at < len(lines) and not pattern.fullmatch(lines[at].strip()):
                at += 1
            assert at < len(lines), (
                f"docs/{doc}: `calibrator {' '.join(step.args)}` did not print "
                f"{printed!r}; it printed:\n{done.stdout}"
            )
            at += 1
        outcomes.append(done)
    return outcomes
