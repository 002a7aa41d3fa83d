"""``measure`` as a procedure: the plan's poses measured into a session file.

The plan is ``options.plan`` (a plan file's), else one of ``options.poses``
made and checked by the run; the document is the session (Parquet, tracker
frame, :mod:`calibrator.session`); a warm-up may move through the plan's
moves first. From Python::

    from calibrator import robots
    from calibrator.acquire import measure
    from calibrator.acquire.run import RunOptions
    from drivers.devices import Devices

    summary = measure.run(robots.get("ur10e"), RunOptions(poses=30), "s.parquet", Devices())
    summary.written        # Path("s.parquet"), or None when no pose was measured
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from calibrator.acquire import ports, procedure
from calibrator.acquire.run import MeasureRun, RunOptions, Summary


class Measure(procedure.Procedure):
    """The measure procedure.

    Parameters
    ----------
    arm, options, output, settle_s
        See :class:`calibrator.acquire.procedure.Procedure`.
    warm_up_min : float
        Move through the plan's moves for about this long first, min, without
        measuring (a robot the run commands only).
    """

    label = "measure"

    def __init__(
        self,
        arm: Any,
        options: RunOptions,
        output: str | Path,
        *,
        settle_s: float | None = None,
        warm_up_min: float = 0.0,
    ) -> None:
        super().__init__(arm, options, Path(output), settle_s=settle_s)
        self.warm_up_min = warm_up_min

    def connected(self, run: MeasureRun, operator: procedure.Operator) -> None:
        from calibrator.acquire import warmup

        warning = warmup.tracker_warning(run.tracker)
        if warning:
            operator.say(f"warning: {warning}")

    def before_measuring(
        self, run: MeasureRun, should_stop: Callable[[], bool], operator: procedure.Operator
    ) -> None:
        from calibrator.acquire import warmup

        if self.warm_up_min > 0:
            passes = warmup.warm_up_run(run, self.warm_up_min, should_stop)
            operator.say(
                f"warmed up: {passes} pass(es) of the plan's moves, no readings", chatter=True
            )


def run(
    arm: Any,
    options: RunOptions,
    output: str | Path,
    devices: ports.Devices,
    operator: procedure.Operator | None = None,
    *,
    settle_s: float | None = None,
    warm_up_min: float = 0.0,
) -> Summary:
    """Measure a session: the plan's poses, journalled, written to ``output`` (Parquet).

    Parameters
    ----------
    arm : calibrator.robots.RobotDescription
    options : calibrator.acquire.run.RunOptions
        The plan (or how many poses to plan), readings, speeds, resume...
    output : str or Path
        The session file; its journal goes beside it.
    devices : calibrator.acquire.ports.Devices
        ``drivers.devices.Devices(robot_url, tracker_url)``.
    operator : calibrator.acquire.procedure.Operator, optional
        Default: silent, no confirmation before a real arm moves.
    settle_s, warm_up_min
        See :class:`Measure`.

    Returns
    -------
    calibrator.acquire.run.Summary
    """
    measure = Measure(arm, options, output, settle_s=settle_s, warm_up_min=warm_up_min)
    return procedure.run(measure, devices, operator)
