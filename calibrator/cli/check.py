"""``calibrator check``: a quick re-check of a calibrated arm (docs/check.md).

Parses, confirms and prints only: the check is the procedure of
:mod:`calibrator.check.procedure` (its poses from :mod:`calibrator.check.poses`,
the cell sequence of :mod:`calibrator.acquire.procedure`: same plan checks,
journal, resume, confirmation and Ctrl-C as ``measure``), the verdict and
its explanation from :mod:`calibrator.check`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer

from calibrator.cli import _checks as checks
from calibrator.cli import _options as opts
from calibrator.cli import _run
from calibrator.cli._app import app
from calibrator.cli._options import fail
from calibrator.cli._run import triple

#: Exit code of a finished check per verdict (a script can alarm on it).
EXIT_CODES = {"ok": 0, "drifted": 3, "recalibrate": 4}


@app.command()
@opts.urdf_links
@_run.run_command
def check(
    *,
    robot: str = _run.robot_option(external=True),
    tracker: str = _run.tracker_option(),
    calibration_path: Path = typer.Option(
        ..., "--calibration", help="The calibration to check (calibration.json)."
    ),
    poses: int = typer.Option(
        8, callback=checks.at_least(5), help="Check poses (chosen for joint zeros, base, tool)."
    ),
    cell_file: Path = opts.cell(
        "Cell file (YAML, docs/cell.md): every pose and move is checked against it."
    ),
    readings: int = _run.readings_option("pose"),
    tolerance: float = opts.positive(
        None,
        "Mean error (mm) above which a changed arm needs recalibrating [default: twice the "
        "predicted error].",
    ),
    output: Path = opts.output(
        Path("check.json"), "Verdict (JSON) to write; the check's poses go beside it (.parquet)."
    ),
    run_args: _run.RunArgs,
    tracker_at: str = opts.tracker_at(
        "Tracker position in the robot base frame X,Y,Z (mm) [default: where the "
        "calibration's base frame puts it]."
    ),
    seed: int = opts.seed(
        0,
        "Seed of the pose choice and of the simulated cell (its hidden arm: the seed the "
        "calibration was measured with, unless a --world file gives one).",
    ),
    world: Path = typer.Option(None, "--world", help=_run.WORLD_HELP),
    session_file: Path = typer.Option(
        None,
        "--session",
        metavar="FILE",
        help="Judge this recorded session (.parquet, tracker frame) instead of measuring: "
        "a re-check measured earlier or by another tool.",
    ),
    history: str = typer.Option(
        None, "--history", help="Record the check in this history (a file or a database URL)."
    ),
    circle: bool = typer.Option(
        False,
        "--circle",
        help="Run the quick circle test instead of the pose check: one circle clockwise then "
        "counter-clockwise, its radius error, out-of-roundness and reversal marks, verdict ok "
        "or flagged (simulated cell only; docs/check.md).",
    ),
    circle_speed: float = typer.Option(
        100.0, "--circle-speed", help="Tool speed along the --circle test, mm/s."
    ),
    quiet: bool = opts.quiet(),
) -> None:
    """Measure a few poses and compare them with the calibration: ok, drifted or recalibrate.

    Writes OUTPUT (JSON) and the measured poses beside it (.parquet). Exit code
    0 ok, 3 drifted, 4 recalibrate, 1 when the run did not finish.
    """
    from calibrator import calibration as calibrations
    from calibrator import cell as cells
    from calibrator import outputs
    from calibrator.acquire import procedure
    from calibrator.acquire.run import RunOptions
    from calibrator.check import document as documents
    from calibrator.check import procedure as checks_run
    from calibrator.cli import _model
    from calibrator.cli._console import Console

    output = Path(output)
    if circle:
        if session_file is not None:
            fail("--circle measures a circle: leave out --session")
        _check_circle(
            calibration_path, output, run_args, world, seed, robot, tracker, tracker_at,
            history, circle_speed,
        )  # fmt: skip
        return
    if session_file is not None:
        _check_recorded(session_file, calibration_path, output, tolerance, history, run_args, world)
        return
    data_path = documents.data_path(output)
    if output.suffix.lower() == ".parquet":
        fail(f"-o {output}: give the JSON file; the check's poses go beside it as .parquet")
    sim_inputs, _ = _run.sim_files(tracker)  # ``sim://?faults=F``
    inputs = [p for p in (calibration_path, cell_file, world) if p is not None] + sim_inputs
    replace_ok = run_args.force or run_args.resume
    outputs.check(output, inputs=inputs, force=replace_ok)
    outputs.check(data_path, inputs=inputs, force=True)
    if not replace_ok and data_path.exists():
        raise outputs.existing(data_path, resumable=True)
    if robot == "external":  # the plan and program written beside OUTPUT: -o's policy
        for companion in _external_files(output):
            outputs.check(companion, inputs=inputs, force=replace_ok)
    if robot == "external" and run_args.resume:
        fail("--resume is not for --robot external: run the check again")
    cal = calibrations.load(calibration_path)
    # The calibration's arm; --model only for one that names none.
    arm = run_args.arm(_model.From(cal.model, calibration_path))
    world_file = _run.read_world(world, robot, tracker)
    if history is not None:  # one it cannot record into is refused before anything moves
        from calibrator.cli.history import refuse_unusable

        refuse_unusable(history)
    options = checks_run.Options(
        cal,
        calibration_path,
        poses=poses,
        tolerance_mm=tolerance,
        tracker_at_mm=triple(tracker_at, "--tracker-at"),
        cell=cells.read_cell(cell_file) if cell_file is not None else None,
        seed=seed,
        run=RunOptions(readings=readings, **run_args.run_fields()),
    )
    check_run = checks_run.prepare(arm, options, output, settle_s=run_args.settle, inputs=inputs)
    external = _external(robot, output, check_run.plan, arm, quiet)
    devices = _run.devices(
        *_run.device_urls(robot, tracker, world_file=world_file),
        world_file=world_file,
        max_speed=run_args.max_speed,
        external=external,
    )
    console = Console(
        quiet=quiet, yes=run_args.yes, estimate=lambda run: f"estimated cell time: {run.estimate()}"
    )
    summary = procedure.run(check_run, devices, console)
    hint = f"rerun the same command with --resume to continue ({summary.journal})"
    doc = check_run.doc
    if summary.stopped or doc is None:
        typer.echo(f"stopped: {summary.stopped or 'no pose measured'}; {hint}", err=True)
        raise typer.Exit(1)
    if summary.failed:
        typer.echo(
            f"{len(summary.failed)} check pose(s) failed ({summary.failed[:10]}): the verdict "
            f"is from {len(doc['poses'])} poses",
            err=True,
        )
    if history is not None:
        _record(history, doc)
    _print_verdict(doc)
    typer.echo(f"wrote {output} and {data_path}")
    raise typer.Exit(EXIT_CODES[doc["verdict"]])


def _check_recorded(
    session_file: Path,
    calibration_path: Path,
    output: Path,
    tolerance: float | None,
    history: str | None,
    run_args: _run.RunArgs,
    world: Path | None,
) -> None:
    """``check --session FILE``: the verdict on a recorded session, written and recorded
    as a measured check's is (the session is the check's data; nothing is measured)."""
    from calibrator import calibration as calibrations
    from calibrator import outputs
    from calibrator.check import recorded as recordings

    if world is not None:
        fail("--world is for a measured check: a recorded session was measured already")
    if output.suffix.lower() == ".parquet":
        fail(f"-o {output}: give the JSON file; the session is the check's data")
    inputs = [session_file, calibration_path]
    outputs.check(output, inputs=inputs, force=run_args.force)
    if history is not None:  # one it cannot record into is refused before any work
        from calibrator.cli.history import refuse_unusable

        refuse_unusable(history)
    cal = calibrations.load(calibration_path)
    model = _checkable(cal, calibration_path)
    session = recordings.read(session_file)
    if session.model and cal.model and session.model != cal.model:
        fail(f"{session_file} measured a {session.model}; {calibration_path} calibrates a "
             f"{cal.model}")  # fmt: skip
    if history is not None and session.robot is None:
        fail(f"{session_file} names no robot (its footer's measured.robot): it cannot be recorded")
    info = {
        "model": cal.model or session.model,
        "calibration": str(calibration_path),
        "calibration_sha256": calibrations.digest(calibration_path),
        "data": str(session_file),
        "session_sha256": calibrations.digest(session_file),
        "conditions": {"started": session.measured_at},
    }
    doc = recordings.check(model, session, tolerance, info)
    import json

    with outputs.Outputs(inputs=inputs) as batch:
        batch.text(output, json.dumps(doc, indent=2, allow_nan=False) + "\n")
    if history is not None:
        _record(history, doc)
    _print_verdict(doc)
    typer.echo(f"wrote {output}")
    raise typer.Exit(EXIT_CODES[doc["verdict"]])


def _checkable(cal: Any, path: Path) -> Any:
    """The calibration as a check's model; one line (exit 2) for one a check cannot use."""
    from calibrator.check.procedure import checkable
    from calibrator.errors import CalibrationError

    try:
        return checkable(cal, path)
    except CalibrationError as exc:
        fail(str(exc))


#: Exit code of a finished circle test per verdict.
CIRCLE_EXIT_CODES = {"ok": 0, "flagged": 3}


def _check_circle(
    calibration_path: Path,
    output: Path,
    run_args: _run.RunArgs,
    world: Path | None,
    seed: int,
    robot: str,
    tracker: str,
    tracker_at: str | None,
    history: str | None,
    speed_mm_s: float,
) -> None:
    """``check --circle``: the circle both ways with compensated commands, its verdict."""
    from calibrator import calibration as calibrations
    from calibrator import outputs
    from calibrator.check import circle_procedure as circle_test
    from calibrator.cli import _model
    from calibrator.errors import CalibrationError

    if not (_run.is_sim(robot) and _run.is_sim(tracker)):
        fail(
            "--circle runs on the simulated cell only "
            "(--robot sim, --tracker sim or emscon+sim) for now"
        )
    if not (0.0 < speed_mm_s <= 5000.0):
        fail(f"--circle-speed must be in (0, 5000] mm/s, got {speed_mm_s:g}")
    if output.suffix.lower() == ".parquet":
        fail(f"-o {output}: give the JSON file of the circle test")
    inputs = [p for p in (calibration_path, world) if p is not None]
    outputs.check(output, inputs=inputs, force=run_args.force)
    cal = calibrations.load(calibration_path)
    arm = run_args.arm(_model.From(cal.model, calibration_path))
    world_file = _run.read_world(world, robot, tracker)
    if history is not None:  # one it cannot record into is refused before anything moves
        from calibrator.cli.history import refuse_unusable

        refuse_unusable(history)
    options = circle_test.Options(
        cal, calibration_path, speed_mm_s, triple(tracker_at, "--tracker-at"), seed
    )
    devices = _run.devices(
        *_run.device_urls(robot, tracker, world_file=world_file), world_file=world_file
    )
    try:
        doc = circle_test.run(arm, options, output, devices, inputs=inputs).document
    except CalibrationError as exc:
        fail(str(exc))
    section = doc["circle"]
    lim = section["limits_mm"]
    typer.echo(
        f"circle r = {section['commanded']['radius_mm']:.1f} mm at {speed_mm_s:g} mm/s, "
        "clockwise then counter-clockwise, compensated commands, robot base frame"
    )
    typer.echo(
        f"radius error {section['radius_error_mm']:+.4f} mm (limit {lim['radius_error_mm']:g})   "
        f"out-of-roundness {section['out_of_roundness_mm']:.4f} mm "
        f"(limit {lim['out_of_roundness_mm']:g})   reversal marks "
        f"{section['reversal_mm']:.4f} mm (limit {lim['reversal_mm']:g})"
    )
    typer.echo(
        f"centre offset {section['centre_offset_norm_mm']:.4f} mm   direction gap "
        f"{section['direction_gap_mm']:.4f} mm"
    )
    typer.echo(f"verdict: {section['verdict']}")
    typer.echo(f"wrote {output}")
    if history is not None:
        _record_circle(history, doc, output)
    raise typer.Exit(CIRCLE_EXIT_CODES[section["verdict"]])


def _record_circle(url: str, doc: dict, output: Path) -> None:
    """Record the circle test in the history at ``url`` (its file is written already)."""
    from calibrator.history import HistoryError

    try:
        with _open_history(url) as store:
            number = store.record_circle_check(doc)
    except HistoryError as exc:
        fail(
            f"wrote {output} but did not record it ({exc}); record it with: "
            "calibrator history import"
        )
    typer.echo(f"recorded circle check {number} in {url}")


def _external_files(output: Path) -> tuple[Path, Path]:
    """The plan and program ``--robot external`` writes beside OUTPUT."""
    return output.with_suffix(".plan.csv"), output.with_suffix(".program.csv")


def _external(robot, output, plan, arm, quiet) -> Any:
    """``--robot external``: write the check's plan and program beside OUTPUT; its options."""
    if robot != "external":
        return None
    from calibrator import outputs, planning
    from calibrator.cli.measure import _external_options
    from calibrator.languages import writing as programs

    plan_file, program_file = _external_files(output)
    spec = programs.ProgramSpec(
        plan_rad=plan.q_rad,
        home_rad=plan.q_rad[0],
        speed_rad_s=arm.move_speed_cap_rad_s,
        accel_rad_s2=arm.move_accel_cap_rad_s2,
        max_joint_speed_rad_s=arm.max_joint_speed_rad_s,
        dwell_s=2.0,
        pulse_output=None,
        name="calibrator_check",
        model=arm.name,
        via_rad=plan.via_rad,
        # The controller's angles, rounded inside the limits, as `program` writes them.
        joint_limits_rad=arm.joint_limits_rad,
        convention=arm.convention,
    )
    with outputs.Outputs() as batch:
        batch.text(plan_file, planning.plan_text(plan, arm))
        batch.text(program_file, programs.render(spec, "csv"))
    typer.echo(
        f"wrote {plan_file} and {program_file}: run them on the controller "
        f"(`calibrator program {plan_file} -o FILE` for its language) once the check waits",
        err=True,
    )
    return _external_options(0.05, 0.5, 15.0, 30.0, quiet)


def _open_history(url: str) -> Any:
    """``--history``: the history opened (the history package, imported only when asked)."""
    try:
        from calibrator.history import open_history  # type: ignore[import-not-found]
    except ImportError:
        fail("--history: this installation has no history support (calibrator.history)")
    return open_history(url)


def _record(url: str, doc: dict) -> None:
    """Record the check in the history at ``url``."""
    with _open_history(url) as store:
        number = store.record_check(doc)
    typer.echo(f"recorded check {number} in {url}")


def _print_verdict(doc: dict) -> None:
    typer.echo("pose   distance mm   predicted RMS mm")
    for p in doc["poses"]:
        typer.echo(f"{p['pose']:4d}   {p['distance_mm']:11.4f}   {p['predicted_rms_mm']:16.4f}")
    typer.echo(
        f"measured {doc['measured_mm']:.4f} mm mean error, predicted {doc['predicted_mm']:.4f} mm "
        f"(chi2 {doc['chi2']:.1f} on {doc['dof']}, p = {doc['p_value']:.2g})"
    )
    typer.echo(f"verdict: {doc['verdict']}")
    for line in doc["explanation_text"]:
        typer.echo(f"  {line}")
