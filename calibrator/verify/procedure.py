"""The ISO 9283 pose test as a cell procedure: its plan, its options, its document.

The plan is ``cycles`` times P5..P1 on the test cube (:func:`calibrator.verify.pose.make_plan`),
measured by the one cell sequence (:mod:`calibrator.acquire.procedure`: the
same checks, journal, resume, confirmation and stops as ``measure``); the
document is verify.json and the attained poses beside it
(:func:`calibrator.verify.pose.write`), written only when every visit of every
cycle was measured. From Python::

    from calibrator import robots
    from calibrator.verify import procedure as verify
    from drivers.devices import Devices

    result = verify.run(robots.get("ur10e"), verify.Options(cycles=3), "v.json", Devices())
    result.document["poses"][0]["AP_mm"]
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from calibrator.acquire import ports, procedure
from calibrator.acquire.run import MeasureRun, RunOptions, Summary
from calibrator.model import frames
from calibrator.verify import pose


@dataclass(frozen=True)
class Options:
    """What one pose test does.

    Attributes
    ----------
    cycles : int
        Cycles P5..P1 (ISO 9283: 30).
    cube : calibrator.verify.iso9283.Cube, optional
        The test cube in the controller's base frame, mm; None: the largest that fits.
    tool_mm : tuple of 3 float
        Nominal TCP on the flange, mm (the controller's tool).
    calibration : calibrator.calibration.Calibration, optional
        Compensate the commands with it (the "after" test); its base frame
        registers the tracker unless ``registration`` is given.
    calibration_path : Path, optional
        Where ``calibration`` was read (recorded in the document).
    registration : calibrator.verify.pose.Registration, optional
        The tracker's registration with the base frame; None: the
        calibration's, else the simulated cell's survey, else a best fit on
        the attained poses (AP then a lower bound).
    cell : calibrator.cell.Cell, optional
        The robot's surroundings: the cube, its poses and every move are checked against it.
    tracker_at_mm : tuple of 3 float, optional
        Where the test poses face (robot base frame, mm); None: the cell's,
        else where the devices say the tracker stands (a simulated cell).
    seed : int
        Seed of the simulated cell.
    run : calibrator.acquire.run.RunOptions
        Readings, retries, speeds, resume and force of the run (its plan,
        cell, tool and tracker fields are the test's).
    """

    cycles: int = 30
    cube: Any = None
    tool_mm: tuple[float, float, float] = (0.0, 0.0, 100.0)
    calibration: Any = None
    calibration_path: Path | None = None
    registration: pose.Registration | None = None
    cell: Any = None
    tracker_at_mm: tuple[float, float, float] | None = None
    seed: int = 0
    run: RunOptions = field(default_factory=RunOptions)


@dataclass
class Result:
    """How a pose test ended: the run's summary and, when written, its document.

    Attributes
    ----------
    summary : calibrator.acquire.run.Summary
    document : dict or None
        verify.json as written; None when no figures were (a visit missing).
    registration : calibrator.verify.pose.Registration or None
        The registration given or the simulated survey; None: a best fit.
    """

    summary: Summary
    document: dict | None
    registration: pose.Registration | None


class PoseTest(procedure.Procedure):
    """The pose test over a checked plan (:func:`prepare` makes it)."""

    label = "verify"

    def __init__(
        self,
        arm: Any,
        options: Options,
        vplan: pose.VerifyPlan,
        output: Path,
        *,
        settle_s: float | None = None,
        inputs: list[Path] | tuple[Path, ...] = (),
    ) -> None:
        run_options = pose.run_options(
            vplan,
            **{
                **_run_fields(options.run),
                "cell": options.cell,
                "seed": options.seed,
                "tool_mm": options.tool_mm,
                # The run checks its plan with the tracker the poses were made to face.
                "tracker_at_mm": options.tracker_at_mm,
            },
        )
        super().__init__(arm, run_options, Path(output), settle_s=settle_s)
        self.test, self.vplan, self.inputs = options, vplan, list(inputs)
        self.registration = options.registration
        if self.registration is None and options.calibration is not None:
            self.registration = pose.from_calibration(options.calibration, options.calibration_path)
        self.doc: dict | None = None

    def opened(self, run: MeasureRun, devices: ports.Opened) -> None:
        if self.registration is None and devices.surveyed_base2tracker is not None:
            # The simulated cell's base, as a user would survey it.
            self.registration = pose.surveyed(
                devices.surveyed_base2tracker, "simulated cell survey"
            )

    def document(self, run: MeasureRun, outcome: Any) -> Path | None:
        # ISO 9283 needs every visit of every cycle: no figures from part of them.
        if outcome.stopped or outcome.failed:
            return None
        path = self.test.calibration_path
        info = {
            "model": self.arm.name,
            "robot": run.robot_id,
            "tracker": run.tracker_id,
            "readings": self.options.readings,
            "calibration": str(path) if path else None,
            "tool_mm": [float(v) for v in self.test.tool_mm],
        }
        self.doc = pose.write(
            self.output,
            outcome.records,
            self.vplan,
            self.registration,
            info=info,
            inputs=self.inputs,
        )
        return self.output


def _run_fields(run: RunOptions) -> dict[str, Any]:
    """The fields of ``run`` a pose test takes as they are (the loop's and the journal's)."""
    keep = ("readings", "retries", "speed_rad_s", "accel_rad_s2", "resume", "force")
    return {name: getattr(run, name) for name in keep}


def prepare(
    arm: Any,
    options: Options,
    output: str | Path,
    devices: ports.Devices,
    *,
    settle_s: float | None = None,
    inputs: list[Path] | None = None,
) -> PoseTest:
    """The test's plan, checked before any device is opened (a cube out of reach is refused).

    ``inputs``: files the outputs must not overwrite.
    """
    tracker_at_mm = options.tracker_at_mm
    if tracker_at_mm is None and options.cell is not None:
        tracker_at_mm = options.cell.tracker_at_mm
    if tracker_at_mm is None:
        tracker_at_mm = devices.tracker_at_mm(arm, options.seed)
    options = replace(options, tracker_at_mm=tracker_at_mm)
    vplan = pose.make_plan(
        arm,
        frames.transform(translation=options.tool_mm),
        options.cycles,
        options.cube,
        options.calibration,
        tracker_at_mm,
        options.cell,
    )
    return PoseTest(arm, options, vplan, Path(output), settle_s=settle_s, inputs=inputs or [])


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
    """Run the ISO 9283 pose test; write ``output`` (JSON) and its .parquet beside it.

    Raises
    ------
    CalibrationError
        A refusal before the first motion (cube, plan, devices, journal).
    """
    test = prepare(arm, options, output, devices, settle_s=settle_s, inputs=inputs)
    summary = procedure.run(test, devices, operator)
    return Result(summary, test.doc, test.registration)
