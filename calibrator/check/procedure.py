"""The check as a cell procedure: a few poses measured and judged against a calibration.

The plan is a handful of poses chosen for what drifts (:mod:`calibrator.check.poses`),
measured by the one cell sequence (:mod:`calibrator.acquire.procedure`: the
same checks, journal, resume, confirmation and stops as ``measure``); the
document is check.json, its verdict and explanation, and the poses beside it
(:mod:`calibrator.check.document`). From Python::

    from calibrator import calibration, robots
    from calibrator.check import procedure as check
    from drivers.devices import Devices

    cal = calibration.load("calibration.json")
    options = check.Options(cal, Path("calibration.json"))
    result = check.run(robots.get(cal.model), options, "check.json", Devices())
    result.document["verdict"]             # "ok", "drifted" or "recalibrate"
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from calibrator import calibration as calibrations
from calibrator.acquire import ports, procedure, rows
from calibrator.acquire.run import MeasureRun, RunOptions, Summary
from calibrator.check import document as documents
from calibrator.check import poses as check_poses
from calibrator.check.model import Calibrated
from calibrator.errors import CalibrationError
from calibrator.model import frames


@dataclass(frozen=True)
class Options:
    """What one check does.

    Attributes
    ----------
    calibration : calibrator.calibration.Calibration
        The calibration checked (identified in the tracker frame).
    calibration_path : Path
        Where it was read (its digest is recorded).
    poses : int
        Check poses (at least 5).
    tolerance_mm : float, optional
        Mean error above which a changed arm needs recalibrating; None: twice
        the predicted error.
    tracker_at_mm : tuple of 3 float, optional
        Where the tracker stands (robot base frame, mm); None: the cell's,
        else where the calibration's base frame puts it.
    cell : calibrator.cell.Cell, optional
    seed : int
        Seed of the pose choice and of the simulated cell.
    run : calibrator.acquire.run.RunOptions
        Readings, retries, speeds, resume and force of the run.
    """

    calibration: Any
    calibration_path: Path
    poses: int = 8
    tolerance_mm: float | None = None
    tracker_at_mm: tuple[float, float, float] | None = None
    cell: Any = None
    seed: int = 0
    run: RunOptions = field(default_factory=RunOptions)


@dataclass
class Result:
    """How a check ended: the run's summary and, when written, check.json's document."""

    summary: Summary
    document: dict | None


def checkable(cal: Any, path: Path) -> Calibrated:
    """The calibration as a check's model (:class:`calibrator.check.model.Calibrated`).

    Raises
    ------
    CalibrationError
        A calibration a check cannot use: identified in the robot base frame
        (no tracker registration to compare readings with), or without the
        residual noise its predictions need.
    """
    if cal.frame != "tracker":
        raise CalibrationError(
            f"{path} was identified in the robot base frame: a check compares "
            "tracker readings with a calibration that registered the tracker (measure's sessions)"
        )
    model = Calibrated.of(cal)
    if not model.sigma_mm > 0:
        raise CalibrationError(
            f"{path} records no residual noise (its uncertainty): the check cannot "
            "predict its error; identify the session again with this version"
        )
    return model


class Check(procedure.Procedure):
    """The check over its chosen poses (:func:`prepare` makes it).

    ``output`` is check.json; the run's journal and poses go beside it
    (:func:`calibrator.check.document.data_path`).
    """

    label = "check"

    def __init__(
        self,
        arm: Any,
        options: Options,
        output: Path,
        *,
        settle_s: float | None = None,
        inputs: list[Path] | tuple[Path, ...] = (),
    ) -> None:
        cal = options.calibration
        self.model = checkable(cal, options.calibration_path)
        tool_mm = tuple(float(v) for v in cal.flange2tool[:3, 3])
        # Where the calibration found the tracker, unless told otherwise.
        at = options.tracker_at_mm
        tracker_at_mm = at if at is not None else tuple(frames.invert(cal.base2tracker)[:3, 3])
        given_cell = options.cell if options.cell is not None else _default_cell()
        # The simulated tracker moves only to a position the user gave, never to the
        # calibration's estimate of where it already stands.
        cell_given = given_cell.tracker_at_mm is not None
        if at is None and cell_given:
            tracker_at_mm = given_cell.tracker_at_mm
        cell = given_cell.with_tracker(tracker_at_mm)
        self.plan = check_poses.choose(arm, options.poses, cell, tool_mm, seed=options.seed).plan
        r = options.run
        run_options = RunOptions(
            plan=self.plan,
            cell=cell,
            seed=options.seed,
            readings=r.readings,
            tool_mm=tool_mm,  # type: ignore[arg-type]
            tracker_at_mm=tracker_at_mm,  # type: ignore[arg-type]
            need_poses=options.poses,
            retries=r.retries,
            speed_rad_s=r.speed_rad_s,
            accel_rad_s2=r.accel_rad_s2,
            resume=r.resume,
            force=r.force,
        )
        super().__init__(
            arm,
            run_options,
            documents.data_path(output),
            settle_s=settle_s,
            place_tracker=at is not None or cell_given,
        )
        self.check, self.json_output, self.inputs = options, Path(output), list(inputs)
        self.doc: dict | None = None

    def document(self, run: MeasureRun, outcome: Any) -> Path | None:
        numbers, q, points, stderr = documents.measured(outcome.records)
        result = documents.evaluate(self.model, q, points, stderr, self.check.tolerance_mm)
        conditions = measuring_conditions(outcome.records)
        path = self.check.calibration_path
        info = {
            "model": self.arm.name,
            # When the poses were measured (the history files the check under it).
            "measured_at": conditions["started"],
            "robot": run.robot_id,
            "tracker": run.tracker_id,
            "calibration": str(path),
            "calibration_sha256": calibrations.digest(path),
            "readings": self.options.readings,
            "poses_planned": len(self.plan.q_rad),
            "data": self.output.name,
            "conditions": conditions,
        }
        doc = documents.document(
            result, numbers, self.arm.convention.to_controller(q), points, info=info
        )
        table = rows.to_table(outcome.records.values(), self.arm.convention)
        documents.write(self.json_output, doc, table, run.meta, self.inputs)
        self.doc = doc
        return self.json_output


def _default_cell() -> Any:
    from calibrator import cell as cells

    return cells.Cell()


def measuring_conditions(records: dict) -> dict:
    """The measuring conditions a run recorded: its span, the spread, what the devices said."""
    measured = [r for r in records.values() if r["status"] == "measured"]
    times = sorted(r["timestamp"] for r in measured if "timestamp" in r)
    spread = [float(np.linalg.norm(r["std_mm"])) for r in measured]
    return {
        "started": times[0] if times else None,
        "ended": times[-1] if times else None,
        "reading_spread_mm": {"mean": float(np.mean(spread)), "max": float(np.max(spread))},
        **rows.summarise(measured),
    }


def prepare(
    arm: Any,
    options: Options,
    output: str | Path,
    *,
    settle_s: float | None = None,
    inputs: list[Path] | None = None,
) -> Check:
    """The check with its poses chosen, before any device is opened.

    Raises
    ------
    CalibrationError
        A calibration a check cannot use (:func:`checkable`), or no poses to check.
    """
    return Check(arm, options, Path(output), settle_s=settle_s, inputs=inputs or [])


def run(
    arm: Any,
    options: Options,
    output: str | Path,
    devices: ports.Devices,
    operator: procedure.Operator | None = None,
    *,
    settle_s: float | None = None,
    inputs: list[Path] | None = None,
) -> Result:
    """Measure the check's poses and judge them; write ``output`` (JSON) and its .parquet.

    Returns
    -------
    Result
        ``document`` None when no pose was measured.
    """
    check = prepare(arm, options, output, settle_s=settle_s, inputs=inputs)
    summary = procedure.run(check, devices, operator)
    return Result(summary, check.doc)
