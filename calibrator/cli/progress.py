"""Progress of long work: a live bar on a terminal, plain lines when piped, nothing when quiet.

Progress goes to stderr, so stdout keeps only results. Use::

    from calibrator.cli import progress

    reporter = progress.Reporter.for_cli(quiet)          # mode from stderr: a tty or not
    with reporter.task("swarm", total=generations, unit="generations") as task:
        for i in range(generations):
            ...
            task.update(i + 1, best=cost)                 # units done so far, extra fields

Modes:

``rich``
    On a terminal: a `rich <https://rich.readthedocs.io>`_ bar with the
    count, elapsed time, ETA and the extra fields.
``plain``
    When stderr is not a terminal: one line per ``interval_s`` (default 2 s)
    and one when the task ends, ``key=value`` pairs separated by spaces::

        progress task=swarm done=400 total=2000 unit=generations elapsed_s=0.2 eta_s=0.8 best=12.3

    ``eta_s`` is ``elapsed * (total - done) / done`` (absent before the first
    unit); the last line of a task has ``done=total`` or, if it stopped
    early, the units it finished and ``stopped=1``.
``off``
    Nothing (``--quiet``).
"""

from __future__ import annotations

import sys
import time
from typing import Any, TextIO

__all__ = ["Reporter", "Task"]

MODES = ("rich", "plain", "off")


class Reporter:
    """Where and how progress is shown.

    Parameters
    ----------
    mode : {'rich', 'plain', 'off'}
    stream : file, optional
        Text stream (default: ``sys.stderr``).
    interval_s : float
        Plain mode: least time between two lines of one task (s).
    """

    def __init__(
        self, mode: str = "plain", stream: TextIO | None = None, interval_s: float = 2.0
    ) -> None:
        if mode not in MODES:
            raise ValueError(f"progress mode must be one of {MODES}, got {mode!r}")
        self.mode = mode
        self.stream = stream if stream is not None else sys.stderr
        self.interval_s = interval_s

    @classmethod
    def for_cli(cls, quiet: bool = False, stream: TextIO | None = None) -> Reporter:
        """``off`` when quiet, ``rich`` on a terminal, ``plain`` otherwise."""
        stream = stream if stream is not None else sys.stderr
        if quiet:
            return cls("off", stream)
        isatty = getattr(stream, "isatty", lambda: False)
        return cls("rich" if isatty() else "plain", stream)

    def task(self, name: str, total: int, unit: str = "steps") -> Task:
        """A :class:`Task` to use as a context manager."""
        return Task(self, name, total, unit)


class Task:
    """One piece of long work with a known number of units."""

    def __init__(self, reporter: Reporter, name: str, total: int, unit: str) -> None:
        self.reporter, self.name, self.total, self.unit = reporter, name, int(total), unit
        self.done = 0
        self.fields: dict[str, object] = {}
        self._started = 0.0  # set again on entering the task
        self._last_shown = 0.0
        self._bar: Any = None  # a rich Progress, made on entering in "rich" mode

    def __enter__(self):
        self._started = time.monotonic()
        self._last_shown = self._started
        if self.reporter.mode == "rich":
            self._start_bar()
        return self

    def __exit__(self, kind, exc, tb):
        if self.reporter.mode == "rich" and self._bar is not None:
            self._bar.update(self._bar_task, completed=self.done, info=self._info())
            self._bar.stop()
        elif self.reporter.mode == "plain" and kind is None:
            # After a failure the error line tells the story; no last progress line.
            self._line(stopped=self.done < self.total)
        return False

    @property
    def elapsed_s(self) -> float:
        """Seconds since the task started."""
        return time.monotonic() - self._started

    def update(self, done: int, **fields: object) -> None:
        """Record ``done`` units finished and any extra fields (shown as ``key=value``)."""
        self.done = int(done)
        self.fields.update(fields)
        mode = self.reporter.mode
        if mode == "off":
            return
        now = time.monotonic()
        if mode == "plain":
            if now - self._last_shown >= self.reporter.interval_s and self.done < self.total:
                self._last_shown = now
                self._line()
        elif now - self._last_shown >= 0.05:  # rich redraws on its own; feed it 20 times a second
            self._last_shown = now
            self._bar.update(self._bar_task, completed=self.done, info=self._info())

    def _eta_s(self):
        if self.done <= 0:
            return None
        return self.elapsed_s * (self.total - self.done) / self.done

    def _info(self):
        return "  ".join(f"{k} {_fmt(v)}" for k, v in self.fields.items())

    def _line(self, stopped=False):
        parts = [
            f"task={self.name}",
            f"done={self.done}",
            f"total={self.total}",
            f"unit={self.unit}",
            f"elapsed_s={self.elapsed_s:.2f}",
        ]
        eta = self._eta_s()
        if eta is not None and self.done < self.total and not stopped:
            parts.append(f"eta_s={eta:.2f}")
        parts += [f"{k}={_fmt(v)}" for k, v in self.fields.items()]
        if stopped:
            parts.append("stopped=1")
        print("progress " + " ".join(parts), file=self.reporter.stream, flush=True)

    def _start_bar(self):
        from rich.console import Console
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TextColumn,
            TimeElapsedColumn,
            TimeRemainingColumn,
        )

        console = Console(file=self.reporter.stream)
        self._bar = Progress(
            TextColumn("{task.description}"),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn(self.unit),
            TimeElapsedColumn(),
            TextColumn("ETA"),
            TimeRemainingColumn(),
            TextColumn("{task.fields[info]}"),
            console=console,
            transient=True,
        )
        self._bar.start()
        self._bar_task = self._bar.add_task(self.name, total=self.total, info="")


def _fmt(value):
    if isinstance(value, float):
        return f"{value:.6g}"
    return str(value).replace(" ", "_")
