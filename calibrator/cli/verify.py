"""``calibrator verify``: the ISO 9283 pose test (AP, RP), before or after calibration."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer

from calibrator.cli import _checks as checks
from calibrator.cli._app import app
from calibrator.cli.measure import (
    _check_motion_caps,
    _confirm,
    _fail,
    _pose_fields,
    _StopOnSigint,
    _triple,
)


def _cube(text: str | None):
    """``X,Y,Z,SIDE`` (mm) to a cube, or None."""
    if text is None:
        return None
    import numpy as np

    from calibrator.iso9283 import Cube

    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if len(values) != 4 or not all(np.isfinite(values)) or values[3] <= 0:
        _fail(f"--cube needs X,Y,Z,SIDE in mm (centre and a positive edge), got {text!r}")
    return Cube(np.array(values[:3]), values[3])


def parquet_path(output: Path) -> Path:
    """Where the attained poses of ``verify.json`` go: ``verify.parquet`` beside it."""
    return Path(output).with_suffix(".parquet")


@app.command()
def verify(
    robot: str = typer.Option("sim", help="sim, or ur://HOST (a real UR controller)."),
    tracker: str = typer.Option(
        "sim",
        help="sim, a device path, a pyserial URL (socket://, rfc2217://), "
        "or emscon://HOST[:PORT][?meteo=T,P,H] (a Leica tracker's emScon server).",
    ),
    calibration_path: Path = typer.Option(
        None,
        "--calibration",
        help="Compensate the commands with this calibration (the 'after' test); "
        "its base frame registers the tracker.",
    ),
    register_path: Path = typer.Option(
        None,
        "--register",
        help="Register the tracker with this calibration's base frame, commands left "
        "nominal (a 'before' test in the same frame as the 'after' one).",
    ),
    base_frame: str = typer.Option(
        None,
        "--base-frame",
        help="Register the tracker with a surveyed robot base frame X,Y,Z,RX,RY,RZ: its "
        "origin (mm) and rotation vector (rad) in the tracker frame [default without "
        "--calibration or --register: the simulated cell's surveyed base, or a best fit "
        "on hardware; see docs/verify.md].",
    ),
    cycles: int = typer.Option(30, callback=checks.at_least(2), help="Cycles P5..P1."),
    cube: str = typer.Option(
        None, help="Test cube X,Y,Z,SIDE, mm, base frame [default: the largest that fits]."
    ),
    readings: int = typer.Option(
        10, callback=checks.at_least(1), help="Readings averaged per attained pose."
    ),
    output: Path = typer.Option(
        Path("verify.json"),
        "-o",
        "--output",
        help="Figures (JSON) to write; the attained poses go beside it (.parquet).",
    ),
    resume: bool = typer.Option(False, help="Continue the run recorded in OUTPUT.journal."),
    yes: bool = typer.Option(False, "--yes", help="Move a real robot without asking."),
    model: str = typer.Option("ur10e", help="Named model of the arm."),
    settle: float = typer.Option(
        None,
        callback=checks.finite(minimum=0.0),
        help="Wait after each move, s [default: 0.5 for ur://, 0 for sim].",
    ),
    retries: int = typer.Option(
        3, callback=checks.at_least(0), help="Re-measurements of a pose after a lost reading."
    ),
    speed: float = typer.Option(
        0.5,
        callback=checks.finite(0.0, inclusive=False),
        help="Leading-joint speed, rad/s (at most the model's fixed ceiling, 1.0).",
    ),
    accel: float = typer.Option(
        1.0,
        callback=checks.finite(0.0, inclusive=False),
        help="Leading-joint acceleration, rad/s^2 (at most the model's fixed ceiling, 2.0).",
    ),
    max_speed: float = typer.Option(
        None,
        callback=checks.finite(0.0, inclusive=False),
        help="Lower the speed cap the plan is checked against, rad/s.",
    ),
    tracker_at: str = typer.Option(
        None, help="Tracker position in the robot base frame X,Y,Z (mm)."
    ),
    tool: str = typer.Option(
        "0,0,100", help="Nominal TCP on the flange X,Y,Z, mm (the controller's tool)."
    ),
    seed: int = typer.Option(0, callback=checks.at_least(0), help="Seed of the simulated cell."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress display."),
    sim_noise: bool = typer.Option(True, hidden=True),
    sim_repeatability: bool = typer.Option(
        True, hidden=True, help="Joint positioning error and backlash of the simulated arm."
    ),
    sim_faults: Path = typer.Option(None, hidden=True, help="Fault script for the simulator."),
    sim_control: str = typer.Option(None, hidden=True),
):
    """ISO 9283 pose test: P5..P1 for --cycles cycles; AP and RP per test pose.

    Writes OUTPUT (figures, JSON) and OUTPUT with .parquet (every attained pose),
    both in the robot base frame; see docs/verify.md.
    """
    import contextlib

    from calibrator import calibration as calibrations
    from calibrator import frames, outputs, progress
    from calibrator.acquire import journal as journals
    from calibrator.acquire import loop
    from calibrator.acquire import verify as run
    from calibrator.acquire.ports import PortError
    from calibrator.cli import _hardware
    from calibrator.errors import CalibrationError

    output = Path(output)
    data_path = parquet_path(output)
    if output.suffix.lower() == ".parquet":
        _fail(f"-o {output}: give the JSON file; the attained poses go beside it as .parquet")
    if calibration_path is not None and (register_path is not None or base_frame is not None):
        _fail("--calibration already registers the tracker: leave out --register/--base-frame")
    if register_path is not None and base_frame is not None:
        _fail("give one registration: --register or --base-frame")
    surveyed_base = _base_frame(base_frame)
    inputs = [p for p in (calibration_path, register_path, sim_faults) if p is not None]
    outputs.check(output, inputs=inputs)
    outputs.check(data_path, inputs=inputs)
    jpath = journals.journal_path(output)
    if not resume:
        for existing in (output, data_path):
            if existing.exists():
                _fail(f"{existing} exists: choose another -o, remove it, or pass --resume")
        if jpath.exists():
            _fail(f"{jpath} exists (an unfinished run): pass --resume to continue it, or remove it")
    if resume and not jpath.exists():
        _fail(f"nothing to resume: {jpath} not found")
    if sim_faults is not None and not Path(sim_faults).is_file():
        _fail(f"file not found: {sim_faults}")
    _check_motion_caps(model, speed, accel, max_speed)
    given_cube = _cube(cube)
    tool_mm = _triple(tool, "--tool")
    cal = calibrations.load(calibration_path) if calibration_path is not None else None
    reg_cal = calibrations.load(register_path) if register_path is not None else None
    for doc, path in ((cal, calibration_path), (reg_cal, register_path)):
        if doc is not None and doc.model and doc.model != model.strip().lower():
            _fail(f"{path} calibrates a {doc.model}, not --model {model}")

    options = _hardware.RigOptions(
        model=model,
        seed=seed,
        sim_noise=sim_noise,
        sim_faults=str(sim_faults) if sim_faults else None,
        sim_control=sim_control,
        max_speed_rad_s=max_speed,
        max_accel_rad_s2=None,
        tracker_at_mm=_triple(tracker_at, "--tracker-at"),
    )
    with contextlib.ExitStack() as stack:
        try:
            rig = _hardware.build(robot, tracker, options, stack)
        except PortError as exc:
            _fail(str(exc))
        # The rig's fields are untyped today (drivers.robot.open_robot will type them).
        arm: Any = rig.model
        robot_port: Any = rig.robot
        _add_sim_repeatability(rig, seed, sim_repeatability)
        flange2tool = frames.transform(translation=tool_mm)
        # ---- the plan, checked whole before anything moves
        vplan = run.make_plan(arm, flange2tool, cycles, given_cube, cal)
        from calibrator import plan as plans

        q_plan = plans.validate(vplan.plan, arm.joint_limits_rad)
        if hasattr(rig.robot, "check_plan"):
            from drivers.robot.errors import LimitsViolation

            try:
                rig.robot.check_plan(q_plan, speed, accel)
            except LimitsViolation as exc:
                _fail(str(exc))
        settle_s = settle if settle is not None else (0.5 if rig.real_robot else 0.0)
        header = {
            "plan_sha256": plans.digest(q_plan),
            "robot": rig.robot_id,
            "tracker": rig.tracker_id,
            "readings": readings,
            "poses": len(q_plan),
            "verify": {
                "cycles": cycles,
                "cube": vplan.cube.to_json(),
                "compensated": cal is not None,
            },
        }
        done: dict = {}
        if resume:
            journal, resumed = journals.Journal.resume(jpath, header)
            done = resumed.records
        todo = [i for i in range(len(q_plan)) if done.get(i, {}).get("status") != "measured"]
        if rig.real_robot and not yes:
            _confirm(rig.robot_id, len(todo) + 1)  # + the lead-in move
        if not resume:
            journal = journals.Journal.create(jpath, header)
        stack.callback(journal.close)
        stopped = None
        if todo:
            try:
                robot_port.move_joints(run.lead_in(vplan, todo[0]), speed, accel)
            except OSError as exc:  # halted, refused or link lost: nothing measured yet
                stopped = f"lead-in move before plan row {todo[0]} failed: {exc}"
        outcome = loop.Outcome(records=dict(done))
        if stopped is None:
            reporter = progress.Reporter.for_cli(quiet)
            with (
                _StopOnSigint() as interrupt,
                reporter.task("verify", len(q_plan), "poses") as task,
            ):
                outcome = loop.run(
                    q_plan,
                    rig.robot,
                    rig.tracker,
                    journal,
                    loop.LoopOptions(readings, settle_s, retries, speed, accel),
                    done=done,
                    after_move=rig.after_move,
                    should_stop=lambda: interrupt.requested,
                    on_pose=lambda p: task.update(p.done, **_pose_fields(p)),
                )
            stopped = outcome.stopped
        journal.close()
        hint = f"rerun the same command with --resume to continue ({jpath})"
        if stopped:
            typer.echo(
                f"stopped: {stopped}; {len(outcome.measured)} of {len(q_plan)} visits kept; "
                + hint,
                err=True,
            )
            raise typer.Exit(1)
        if outcome.failed:
            typer.echo(
                f"{len(outcome.failed)} visit(s) failed after {retries} retries "
                f"({outcome.failed[:10]}); ISO 9283 needs every cycle: " + hint + " to retry them",
                err=True,
            )
            raise typer.Exit(1)
        pts, rotvecs = run.points(outcome.records, vplan)
        if cal is not None:
            registration = run.from_calibration(cal, calibration_path)
        elif reg_cal is not None:
            registration = run.from_calibration(reg_cal, register_path)
        elif surveyed_base is not None:
            registration = run.surveyed(surveyed_base, f"--base-frame {base_frame}")
        elif rig.sim_cell is not None:
            registration = run.surveyed(_sim_survey(rig.sim_cell, seed), "simulated cell survey")
        else:
            typer.echo(
                "note: no --calibration, --register or --base-frame: the tracker is "
                "registered by a best fit on the test poses (AP is a lower bound)",
                err=True,
            )
            registration = run.fit(pts, vplan)
        poses, table = run.evaluate(pts, rotvecs, vplan, registration)
        info = {
            "model": arm.name,
            "robot": rig.robot_id,
            "tracker": rig.tracker_id,
            "readings": readings,
            "calibration": str(calibration_path) if calibration_path else None,
            "tool_mm": [float(v) for v in tool_mm],
            "data": data_path.name,
        }
        doc = run.document(vplan, poses, registration, info=info)
        import json

        try:
            with outputs.Outputs(inputs=inputs) as batch:
                batch.text(output, json.dumps(doc, indent=2, allow_nan=False) + "\n")
                batch.file(data_path, lambda tmp: table.to_parquet(tmp, index=False))
        except ValueError as exc:  # a non-finite figure: no certificate from it
            raise CalibrationError(f"cannot write {output}: {exc}") from None
        jpath.unlink()
    _print_table(doc, output, data_path)


def _base_frame(text: str | None):
    """``X,Y,Z,RX,RY,RZ`` to base2tracker (4, 4), or None."""
    if text is None:
        return None
    import numpy as np

    from calibrator import frames

    try:
        values = np.array([float(v) for v in text.split(",")])
    except ValueError:
        values = np.array([])
    if values.shape != (6,) or not np.isfinite(values).all():
        _fail(f"--base-frame needs X,Y,Z,RX,RY,RZ (mm, rad), got {text!r}")
    return frames.transform(frames.rotvec_to_matrix(values[3:]), values[:3])


#: How well the simulated cell's base frame is surveyed: standard deviation of
#: each translation (mm) and rotation (rad) component, a tracker on base fiducials.
SIM_SURVEY_MM, SIM_SURVEY_RAD = 0.02, 20e-6


def _sim_survey(cell, seed: int):
    """The simulated cell's base frame as a user would survey it: truth plus a seeded error."""
    import numpy as np

    from calibrator import frames

    rng = np.random.default_rng([seed, 9283, 1])
    error = frames.transform(
        frames.rotvec_to_matrix(rng.normal(0.0, SIM_SURVEY_RAD, 3)),
        rng.normal(0.0, SIM_SURVEY_MM, 3),
    )
    return cell.base2tracker @ error


def _add_sim_repeatability(rig, seed: int, enabled: bool) -> None:
    """Give the simulated arm its joint positioning error and backlash (seeded)."""
    if not enabled:
        return
    from drivers.robot.simulated import JointRepeatability, SimulatedRobot

    if isinstance(rig.robot, SimulatedRobot):
        import numpy as np

        # Its own stream, seeded from --seed: the hidden arm (SimCell) stays the same.
        rng = np.random.default_rng([seed, 9283])
        rig.robot.set_repeatability(JointRepeatability.typical(), rng)


def _print_table(doc: dict, output: Path, data_path: Path) -> None:
    reg = doc["registration"]["method"]
    state = "compensated" if doc["compensated"] else "nominal"
    typer.echo(
        f"ISO 9283, {doc['cycles']} cycles, {state} commands, robot base frame "
        f"(registration: {reg})"
    )
    typer.echo("pose     AP mm    APx mm    APy mm    APz mm     RP mm")
    for p in doc["poses"]:
        typer.echo(
            f"P{p['test_pose']}   {p['AP_mm']:8.4f}  {p['APx_mm']:8.4f}  {p['APy_mm']:8.4f}  "
            f"{p['APz_mm']:8.4f}  {p['RP_mm']:8.4f}"
        )
    if not doc["orientation"].startswith("measured"):
        typer.echo("orientation: " + doc["orientation"])
    typer.echo(f"wrote {output} and {data_path}")
