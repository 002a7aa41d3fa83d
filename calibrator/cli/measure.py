"""``calibrator measure``: drive the robot through a plan and record a session with the tracker."""

from __future__ import annotations

import sys
from pathlib import Path

import typer

from calibrator.cli import _checks as checks
from calibrator.cli import _options as opts
from calibrator.cli import _run
from calibrator.cli._app import app
from calibrator.cli._options import fail as _fail
from calibrator.cli._run import triple as _triple


@app.command()
@opts.urdf_links
@_run.run_command
def measure(
    *,
    robot: str = _run.robot_option(external=True),
    tracker: str = _run.tracker_option(),
    plan_path: Path = typer.Option(None, "--plan", help="Plan CSV (calibrator plan)."),
    cell_file: Path = opts.cell(
        "Cell file (YAML, docs/cell.md): mounting plane, obstacles, tracker range; "
        "every pose and move is checked against it before the first motion."
    ),
    poses: int = typer.Option(
        # 30 left a UR10e in the tracker frame 2.9 values per free parameter after the
        # hold-out, and identify warned of its own default.
        40,
        callback=checks.count("plan_poses"),
        help="Poses of the plan made when --plan is not given.",
    ),
    readings: int = _run.readings_option("pose"),
    output: Path = opts.output(Path("session.parquet"), "Session file (Parquet) to write."),
    run_args: _run.RunArgs,
    tracker_at: str = opts.tracker_at(
        "Tracker position in the robot base frame X,Y,Z (mm), for --poses planning."
    ),
    tool: str = opts.tool(
        "Reflector position on the flange X,Y,Z, mm (first guess; identified) [default: the "
        "plan file's, else 0,0,100].",
        default=None,
    ),
    seed: int = opts.seed(0, "Seed of the plan and of the simulated cell."),
    world: Path = typer.Option(None, "--world", help=_run.WORLD_HELP),
    retry_pause: float = typer.Option(
        0.2,
        callback=checks.finite(minimum=0.0, maximum=60.0),
        help="Pause before re-measuring a pose after a lost reading, s; doubled each "
        "further retry (up to 8 times).",
    ),
    warm_up: float = typer.Option(
        0.0,
        "--warm-up",
        callback=checks.finite(minimum=0.0, maximum=600.0),
        help="Move through the plan's moves for about this long first, without measuring, "
        "min (warms the arm; docs/measure.md).",
    ),
    ask_relock: bool = typer.Option(
        True,
        help="On a terminal, ask the operator to re-lock a lost beam (Enter) before a retry.",
    ),
    quiet: bool = opts.quiet(),
    # --robot external: how the tracker's stream is cut into stops and matched to poses.
    stop_band: float = typer.Option(
        0.05,
        callback=checks.seconds("stop_band", positive=True),
        help="--robot external: stationarity band of a stop, mm.",
    ),
    settle_window: float = typer.Option(
        0.5,
        callback=checks.seconds("settle_window", positive=True),
        help="--robot external: how long readings stay in the band to make a stop, s.",
    ),
    match_tolerance: float = typer.Option(
        15.0,
        callback=checks.seconds("match_tolerance", positive=True),
        help="--robot external: most the nominal arm may be off, mm (the bound of the "
        "tolerance a stop is matched with; docs/external-robots.md).",
    ),
    stop_timeout: float = typer.Option(
        30.0,
        callback=checks.seconds("stop_timeout", positive=True),
        help="--robot external: no stop for this long ends the program's poses (missing), s.",
    ),
    timings: bool = typer.Option(False, hidden=True, help="Print where the time went (stderr)."),
) -> None:
    """Measure a session: move, settle, average readings, journal each pose, write Parquet."""
    from calibrator.cli._console import Console

    console = Console(
        quiet=quiet,
        yes=run_args.yes,
        pose_lines=True,  # a line per pose when piped: a measure run is slow enough
        relock=_ask_relock if ask_relock and sys.stdin.isatty() else None,
    )
    from calibrator import outputs, planning
    from calibrator.acquire import measure as measuring
    from calibrator.acquire.run import RunOptions

    output = Path(output)
    if robot == "external" and plan_path is None:
        # A plan made here is one no controller runs: the program comes from a plan file.
        _fail(
            "--robot external needs --plan PLAN: the plan whose program the controller runs "
            "(calibrator program PLAN -o FILE)"
        )
    # A simulated tracker's fault script and recording (``sim://?faults=F&replay=R``).
    sim_inputs, _ = _run.sim_files(tracker)
    inputs = [p for p in (plan_path, cell_file, world) if p is not None] + sim_inputs
    outputs.check(output, inputs=inputs, force=True)
    if not (run_args.force or run_args.resume) and output.exists():
        raise outputs.existing(output, resumable=True)  # before any device is opened
    from calibrator import cell as cells
    from calibrator.cli import _model

    user_plan = planning.read_plan(plan_path) if plan_path is not None else None
    # The plan's arm; --model only for a plan that names none (or none given).
    origin = None if user_plan is None else user_plan.origin
    arm = run_args.arm(_model.From(None if origin is None else origin.model, str(plan_path)))
    world_file = _run.read_world(world, robot, tracker)
    if user_plan is not None and origin is None:
        # A plan naming no arm holds the controller's angles of the arm just resolved.
        user_plan = planning.read_plan(plan_path, arm)
    cell = None if cell_file is None else cells.read_cell(cell_file)
    tracker_mm: tuple[float, float, float] | None = _triple(tracker_at, "--tracker-at")
    if tracker_mm is None and cell is not None:
        tracker_mm = cell.tracker_at_mm
    tool_mm = _triple(tool, "--tool")
    if user_plan is not None:
        # A plan made for another arm, tracker or reflector is refused; what the
        # command line leaves out comes from the plan file.
        tracker_mm, tool_mm = planning.made_for(user_plan, arm, tracker_mm, tool_mm, plan_path)
    options = RunOptions(
        plan=user_plan,
        cell=cell,
        poses=poses,
        seed=seed,
        readings=readings,
        retry_pause_s=retry_pause,
        tool_mm=tool_mm if tool_mm is not None else planning.DEFAULT_TOOL_MM,
        tracker_at_mm=tracker_mm,
        **run_args.run_fields(),
    )
    if warm_up > 0 and robot == "external":
        _fail("--warm-up is for robots measure drives (the external robot runs its own program)")
    console.estimate_of = lambda run: _estimate(run, arm, run_args)
    console.guessed_of = lambda run: _guessed(run, arm)
    external = _external_options(stop_band, settle_window, match_tolerance, stop_timeout, quiet)
    devices = _run.devices(
        *_run.device_urls(robot, tracker, world_file=world_file),
        world_file=world_file,
        max_speed=run_args.max_speed,
        external=external,
    )
    summary = measuring.run(
        arm, options, output, devices, console, settle_s=run_args.settle, warm_up_min=warm_up
    )
    if timings:
        console.print_timings(TIMING_LABELS)
    for line in summary.notes:
        typer.echo(line)
    _report(summary, options, retried=robot != "external")


#: ``--timings``: what each step of the procedure was.
TIMING_LABELS = {
    "connected": "connect (simulator start, links)",
    "planned": "plan (make and check)",
    "measured": "measure loop",
    "written": "write session",
    "closed": "close (devices, simulator)",
}


def _estimate(run, arm, run_args: _run.RunArgs) -> str:
    """The cell-time line: the run's, and a real arm's beside a simulated one's."""
    from calibrator import planning

    options = run.options
    estimate = f"estimated cell time: {run.estimate()}"
    if not run.moves_hardware and run_args.settle is None:
        # plan estimates the real cell, whose arm rings after a move; the simulated one
        # does not: both figures, so the two commands' numbers are one estimate.
        settle = run_args.settle_s(True)
        real = planning.estimate(
            run.plan,
            arm,
            options.speed_rad_s,
            options.accel_rad_s2,
            settle_s=settle,
            readings=options.readings,
        )
        estimate += f"; a real arm settling {settle:g} s a pose (as plan estimates): {real}"
    return estimate


def _guessed(run, arm) -> str | None:
    """What of the arm's collision body is guessed (capsules along the links), or None.

    The arm's body says so, or the plan file made with it (a URDF's meshes missing).
    """
    from calibrator import planning

    origin = run.plan.origin
    return planning.guessed_geometry(arm) or (origin.guessed_geometry if origin else None)


def _external_options(
    band_mm: float, window_s: float, tolerance_mm: float, timeout_s: float, quiet: bool
):
    """``--robot external``: stop detection and association (used by that kind only)."""
    from calibrator.acquire.external import ExternalOptions, StopOptions

    log = None if quiet else (lambda line: typer.echo(line, err=True))
    return ExternalOptions(StopOptions(band_mm, window_s, tolerance_mm, timeout_s), log)


def _report(summary, options, retried: bool = True) -> None:
    """The run's last lines: what was written, what failed and why, what to do next.

    ``retried``: whether a failed pose was retried (a commanded robot's are; an
    external robot's program passes each pose once, and a pose without a stop failed).
    """
    resume_hint = f"rerun the same command with --resume to continue ({summary.journal})"
    causes = f": {summary.causes_text()}" if summary.causes else ""
    failed = f"{len(summary.failed)} pose(s) failed{causes}"
    if summary.written is None:
        what = "; ".join(x for x in (summary.stopped, failed if summary.failed else "") if x)
        typer.echo(
            f"calibrator: error: no pose measured, no session written: {what}; {resume_hint}",
            err=True,
        )
        raise typer.Exit(1)
    if summary.stopped:
        advice = ""
        if summary.stopped.startswith("robot halted"):
            advice = (
                "clear the stop on the pendant (after an e-stop: release it, power on "
                "and release the brakes), then "
            )
        kept = f"{len(summary.measured)} of {summary.total} poses kept"
        typer.echo(
            f"stopped: {summary.stopped}; {kept}"
            + (f"; {failed}" if summary.failed else "")
            + "; "
            + advice
            + resume_hint,
            err=True,
        )
        raise typer.Exit(1)
    if summary.failed:
        typer.echo(
            f"{failed} ("
            + (f"after {options.retries} retries: " if retried else "")
            + f"poses {summary.failed[:10]}); "
            f"wrote {summary.written} with {len(summary.measured)} poses; "
            + resume_hint
            + " to retry them"
        )
        return
    n = len(summary.measured)
    typer.echo(f"wrote {summary.written}: {n} poses x {options.readings} readings")


def _ask_relock(pose: int, attempt: int) -> None:
    """On a terminal: let the operator re-lock the beam before the next attempt."""
    typer.prompt(
        f"beam lost at pose {pose}: re-lock it on the reflector, then press Enter "
        f"(attempt {attempt})",
        default="",
        show_default=False,
        err=True,
    )
