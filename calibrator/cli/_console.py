"""The command line as a cell procedure's operator (:class:`Console`).

Prints the procedure's lines on stderr, asks before a real arm moves, shows
progress and stops after the pose in hand on Ctrl-C
(:class:`calibrator.cli._run.StopOnSigint`); imported by the commands that
run a procedure when they run (``--help`` never loads the domain).
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from typing import Any

import typer

from calibrator.acquire.procedure import Operator, Watch
from calibrator.cli._run import StopOnSigint, confirm, pose_fields


class Console(Operator):
    """The command line as a procedure's operator: prints, asks, stops on Ctrl-C, times.

    Parameters
    ----------
    quiet : bool
        ``--quiet``: no progress display, no chatter.
    yes : bool
        ``--yes``: move a real arm without asking.
    estimate : callable, optional
        ``estimate(run)``: the cell-time line shown before the confirmation
        (or once the journal is open).
    guessed : callable, optional
        ``guessed(run)``: what of the arm's collision body is guessed, or None
        (said in the question, else warned of).
    pose_lines : bool
        A progress line per pose when piped (a slow run).
    relock : callable, optional
        ``relock(pose, attempt)``: ask the operator to re-lock a lost beam.
    """

    def __init__(
        self,
        *,
        quiet: bool,
        yes: bool,
        estimate: Callable[[Any], str] | None = None,
        guessed: Callable[[Any], str | None] | None = None,
        pose_lines: bool = False,
        relock: Callable[[int, int], None] | None = None,
    ) -> None:
        import time

        self.quiet, self.pose_lines, self.relock = quiet, pose_lines, relock
        self.estimate_of, self.guessed_of = estimate, guessed
        self.estimate: str | None = None
        self.guessed: str | None = None
        self.shown = False
        self.confirm = None if yes else self._ask  # type: ignore[assignment]
        #: ``(step, time.perf_counter())`` from the command's start.
        self.marks: list[tuple[str, float]] = [("start", time.perf_counter())]

    def say(self, line: str, *, chatter: bool = False) -> None:
        if not (chatter and self.quiet):
            typer.echo(line, err=True)

    def step(self, name: str) -> None:
        import time

        self.marks.append((name, time.perf_counter()))

    def planned(self, run: Any) -> None:
        self.estimate = None if self.estimate_of is None else self.estimate_of(run)
        self.guessed = None if self.guessed_of is None else self.guessed_of(run)

    def _ask(self, robot_id: str, n: int) -> None:
        if self.estimate is not None:
            typer.echo(self.estimate, err=True)
        self.shown = True
        confirm(robot_id, n, self.guessed)

    def ready(self, run: Any) -> None:
        # Shown before a confirmation is asked, else once the journal is open
        # (a refused resume stays one line).
        if not self.shown and not self.quiet and self.estimate is not None:
            typer.echo(self.estimate, err=True)
        if not self.shown and self.guessed:
            typer.echo(
                f"warning: every pose and move checked against guessed geometry: {self.guessed}",
                err=True,
            )

    @contextlib.contextmanager
    def measuring(self, run: Any, label: str) -> Iterator[Watch]:
        from calibrator.cli import progress

        reporter = progress.Reporter.for_cli(self.quiet)
        if self.pose_lines:
            reporter.interval_s = 0.0
        with (
            StopOnSigint() as interrupt,
            reporter.task(label, len(run.plan.q_rad), "poses") as task,
        ):
            yield Watch(
                should_stop=lambda: interrupt.requested,
                on_pose=lambda p: task.update(p.done, **pose_fields(p)),
                on_beam_lost=self.relock,
            )

    def print_timings(self, labels: dict[str, str]) -> None:
        """``timing: LABEL: S s`` per step on stderr (``--timings``)."""
        for (_, t0), (what, t1) in zip(self.marks, self.marks[1:], strict=False):
            typer.echo(f"timing: {labels.get(what, what)}: {t1 - t0:.3f} s", err=True)
