"""A cell procedure: the one sequence every run of the arm past the tracker follows.

``measure``, ``verify`` and ``check`` differ in their plan, their options and
the document they make of what was measured; the sequence around them is
this module's, once::

    open the devices -> check the files -> connect -> check the plan
    -> open the journal (confirm) -> measure the poses (stoppable)
    -> write the document (all or nothing) -> close the devices

A procedure is a :class:`Procedure` (its arm, its
:class:`~calibrator.acquire.run.RunOptions` holding the plan, its output and
``document(run, outcome)``); the devices are opened through the
:class:`Devices` port (``drivers.devices.Devices`` opens them by URL: real
ones, or the simulated cell); whoever runs it is an :class:`Operator` (the
CLI prints, asks and stops on Ctrl-C; the default one is silent). From
Python::

    from calibrator import robots
    from calibrator.acquire import measure
    from calibrator.acquire.run import RunOptions
    from drivers.devices import Devices

    summary = measure.run(robots.get("ur10e"), RunOptions(poses=30), "s.parquet", Devices())

:func:`run` raises :class:`~calibrator.errors.CalibrationError` for a refusal
(one line naming what was wrong) before anything moves; a failure while
measuring ends the run as :mod:`calibrator.acquire.loop` says, with the
journal kept for a resume.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from contextlib import ExitStack
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from calibrator.acquire import loop
from calibrator.acquire.ports import Devices, Opened
from calibrator.acquire.run import MeasureRun, RunOptions, Summary, tracker_position


@dataclass(frozen=True)
class Watch:
    """What the loop asks while it measures: stop now? and what to say after each pose."""

    should_stop: Callable[[], bool] = lambda: False
    on_pose: Callable[[loop.Progress], None] | None = None
    on_beam_lost: Callable[[int, int], None] | None = None


class Operator:
    """Whoever runs a procedure: told each step, asked before a real arm moves.

    Every hook does nothing here; the CLI's operator prints, asks and stops
    on Ctrl-C (:class:`calibrator.cli._run.Console`). ``confirm`` None moves
    a real arm without asking (a script's call is its consent, as ``--yes``).
    """

    #: ``confirm(robot_id, n)`` before a real arm moves through ``n`` poses; raises to refuse.
    confirm: Callable[[str, int], None] | None = None

    def say(self, line: str, *, chatter: bool = False) -> None:
        """A line for the operator (``chatter``: one a quiet operator may drop)."""

    def step(self, name: str) -> None:
        """``connected``, ``planned``, ``measured``, ``written``, ``closed``: a step ended."""

    def planned(self, run: MeasureRun) -> None:
        """The plan is checked (``run.plan``) and the run's options are final."""

    def ready(self, run: MeasureRun) -> None:
        """The journal is open: the first motion is next."""

    @contextlib.contextmanager
    def measuring(self, run: MeasureRun, label: str) -> Iterator[Watch]:
        """Around the loop (and a warm-up): the :class:`Watch` it is given."""
        yield Watch()


class Procedure:
    """One cell procedure: its arm, run options (with the plan), output and document.

    Subclasses say what is theirs: :meth:`document` (default: the session
    file), and the hooks :meth:`opened`, :meth:`connected` and
    :meth:`before_measuring`.

    Parameters
    ----------
    arm : calibrator.robots.RobotDescription
    options : calibrator.acquire.run.RunOptions
        ``options.plan`` None: the run makes one (``measure``).
    output : Path
        The file the run's journal goes beside (the session or data file).
    settle_s : float, optional
        Wait after each move, s; None: 0.5 s on hardware (a real arm rings
        after a move), 0 simulated.
    place_tracker : bool
        Move a simulated tracker to the run's tracker position; False when that
        position is only an estimate of where the simulated one stands.
    """

    #: What the progress display calls the run.
    label = "measure"

    def __init__(
        self,
        arm: Any,
        options: RunOptions,
        output: Path,
        *,
        settle_s: float | None = None,
        place_tracker: bool = True,
    ) -> None:
        self.arm, self.options, self.output = arm, options, Path(output)
        self.settle_s, self.place_tracker = settle_s, place_tracker

    def settle_for(self, moves_hardware: bool) -> float:
        """The wait after each move, s, for a robot that moves hardware or not."""
        if self.settle_s is not None:
            return self.settle_s
        return 0.5 if moves_hardware else 0.0

    def opened(self, run: MeasureRun, devices: Opened) -> None:
        """The devices are open (not connected) and the files checked.

        ``devices`` holds them and what they know of the cell (a simulated
        cell's tracker position and surveyed base, as plain data).
        """

    def connected(self, run: MeasureRun, operator: Operator) -> None:
        """Both devices answered."""

    def before_measuring(
        self, run: MeasureRun, should_stop: Callable[[], bool], operator: Operator
    ) -> None:
        """Inside the stoppable span, before the first pose (a warm-up)."""

    def document(self, run: MeasureRun, outcome: loop.Outcome) -> Path | None:
        """Write the result of ``outcome`` (all or nothing); its path, or None if nothing."""
        return run.write_session(outcome)


def run(procedure: Procedure, devices: Devices, operator: Operator | None = None) -> Summary:
    """Run ``procedure`` on the devices: the one cell sequence (see the module).

    Returns
    -------
    calibrator.acquire.run.Summary
        How the run ended; ``summary.written`` is the document's path or None.

    Raises
    ------
    CalibrationError
        A refusal before the first motion (files, devices, plan, journal).
    """
    operator = operator if operator is not None else Operator()
    options = procedure.options
    at = tracker_position(options) if procedure.place_tracker else None
    with ExitStack() as stack:
        opened = devices.open(procedure.arm, options.seed, at, stack)
        mrun = stack.enter_context(
            MeasureRun(
                opened.robot,
                opened.tracker,
                procedure.arm,
                options,
                procedure.output,
                tracker_at_mm=opened.tracker_at_mm,
            )
        )
        mrun.check_files()
        procedure.opened(mrun, opened)
        mrun.connect(devices.tracker_url)
        procedure.connected(mrun, operator)
        operator.step("connected")
        mrun.make_plan(on_note=lambda text: operator.say(f"note: {text}"))
        operator.step("planned")
        mrun.options = replace(mrun.options, settle_s=procedure.settle_for(mrun.moves_hardware))
        operator.planned(mrun)
        mrun.open_journal(confirm=operator.confirm)
        operator.ready(mrun)
        with operator.measuring(mrun, procedure.label) as watch:
            procedure.before_measuring(mrun, watch.should_stop, operator)
            mrun.measure(
                should_stop=watch.should_stop,
                on_pose=watch.on_pose,
                on_beam_lost=watch.on_beam_lost,
            )
        operator.step("measured")
        summary = mrun.finish(lambda outcome: procedure.document(mrun, outcome))
        operator.step("written")
    operator.step("closed")
    return summary
