"""``calibrator verify``: the ISO 9283 pose test (AP, RP), before or after calibration.

Parses, confirms and prints only: the test is the procedure of
:mod:`calibrator.verify.procedure` (the cell sequence of
:mod:`calibrator.acquire.procedure`: same checks, journal, resume,
confirmation and Ctrl-C as ``measure``).
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
from calibrator.model import rotations

#: Smallest test cube edge (mm): ISO 9283's five poses spread over the cube (an edge
#: of 1e-300 mm ran a test of five poses at one point).
MIN_CUBE_MM = 10.0


def _cube(text: str | None) -> Any:
    """``X,Y,Z,SIDE`` (mm) to a cube, or None."""
    if text is None:
        return None
    import numpy as np

    from calibrator.verify.iso9283 import Cube

    needs = "X,Y,Z,SIDE in mm (centre and a positive edge)"
    values = opts.floats(text, 4, "--cube", needs)
    if values[3] <= 0:
        fail(f"--cube needs {needs}, got {text!r}")
    # Checked before any arithmetic: 1e308 overflows where the corners are computed.
    limit, unit = checks.BUDGETS["tracker_at"]
    if max(abs(v) for v in values) > limit:
        fail(f"--cube: {text!r} is beyond +-{limit:g} {unit} (not a cube in a robot cell)")
    if values[3] < MIN_CUBE_MM:
        fail(
            f"--cube: an edge of {values[3]:g} mm is below {MIN_CUBE_MM:g} mm "
            "(the test poses would coincide)"
        )
    return Cube(np.array(values[:3]), values[3])


@app.command()
@opts.urdf_links
@_run.run_command
def verify(
    *,
    robot: str = _run.robot_option(external=True),
    tracker: str = _run.tracker_option(),
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
    cycles: int = typer.Option(
        30, callback=checks.count("cycles", 2), help="Cycles P5..P1 (2..1000)."
    ),
    cube: str = typer.Option(
        None,
        help="Test cube X,Y,Z,SIDE, mm, in the controller's base frame "
        "[default: the largest that fits].",
    ),
    readings: int = _run.readings_option("attained pose"),
    output: Path = opts.output(
        Path("verify.json"), "Figures (JSON) to write; the attained poses go beside it (.parquet)."
    ),
    run_args: _run.RunArgs,
    tracker_at: str = opts.tracker_at(
        "Tracker position in the robot base frame X,Y,Z (mm; overrides the cell's)."
    ),
    cell_file: Path = opts.cell(
        "Cell file (YAML, docs/cell.md): mounting plane, obstacles, tracker; the test "
        "cube, its poses and every move of the cycle are checked against it."
    ),
    tool: str = opts.tool("Nominal TCP on the flange X,Y,Z, mm (the controller's tool)."),
    seed: int = opts.seed(0, "Seed of the simulated cell."),
    world: Path = typer.Option(None, "--world", help=_run.WORLD_HELP),
    quiet: bool = opts.quiet(),
    history: str = typer.Option(
        None,
        "--history",
        metavar="FILE|URL",
        help="Also record it in this history (docs/history.md).",
    ),
    path_shape: str = typer.Option(
        None,
        "--path",
        metavar="line|circle|rectangle",
        help="Run the ISO 9283 path test instead of the pose test: a line from P2 to P4, "
        "a circle about P1 or the rectangle P2..P5 in the cube's test plane, streamed by "
        "the tracker (simulated cell only; docs/verify.md).",
    ),
    path_speed: str = typer.Option(
        "100",
        "--path-speed",
        metavar="MM_S|PCT%",
        help="Tool speed along --path: mm/s, or a percentage of the path's rated speed "
        "(ISO 9283's 100%, 50%, 10%; the fastest within the arm's motion ceilings).",
    ),
) -> None:
    """ISO 9283 pose test: P5..P1 for --cycles cycles; AP and RP per test pose.

    Writes OUTPUT (figures, JSON) and OUTPUT with .parquet (every attained pose),
    both in the robot base frame; see docs/verify.md.
    """
    from calibrator import calibration as calibrations
    from calibrator import outputs
    from calibrator.acquire import procedure
    from calibrator.acquire.run import RunOptions
    from calibrator.cli import _model
    from calibrator.cli._console import Console
    from calibrator.verify import pose
    from calibrator.verify import procedure as tests

    output = Path(output)
    data_path = pose.data_path(output)
    if output.suffix.lower() == ".parquet":
        fail(f"-o {output}: give the JSON file; the attained poses go beside it as .parquet")
    if calibration_path is not None and (register_path is not None or base_frame is not None):
        fail("--calibration already registers the tracker: leave out --register/--base-frame")
    if register_path is not None and base_frame is not None:
        fail("give one registration: --register or --base-frame")
    surveyed_base = _base_frame(base_frame)
    if path_shape is not None:
        from calibrator.cli import verify_path

        speed = verify_path.parse_speed(path_speed)
        verify_path.check_options(path_shape, speed, robot, tracker, world, history)
    elif robot == "external":
        fail(
            "--robot external runs the path test only (--path; the pose test needs --robot sim or ur://)"
        )
    sim_inputs, _ = _run.sim_files(tracker)  # ``sim://?faults=F``
    inputs = [p for p in (calibration_path, register_path, cell_file, world) if p is not None]
    inputs += sim_inputs
    replace_ok = run_args.force or run_args.resume
    outputs.check(output, inputs=inputs, force=replace_ok)
    outputs.check(data_path, inputs=inputs, force=True)
    if not replace_ok and data_path.exists():
        raise outputs.existing(data_path, resumable=True)
    cal = calibrations.load(calibration_path) if calibration_path is not None else None
    reg_cal = calibrations.load(register_path) if register_path is not None else None
    # The calibration's arm; --model only for one that names none, or without one.
    given = [(cal, calibration_path), (reg_cal, register_path)]
    arm = run_args.arm(*(_model.From(doc.model, path) for doc, path in given if doc is not None))
    if history is not None:  # a history it could not record into is refused before moving
        from calibrator.cli.history import refuse_unusable

        refuse_unusable(history)
    world_file = _run.read_world(world, robot, tracker)
    from calibrator import cell as cells

    registration = None  # the calibration's, the simulated cell's survey, or a best fit
    if reg_cal is not None:
        registration = pose.from_calibration(reg_cal, register_path)
    elif surveyed_base is not None:
        registration = pose.surveyed(surveyed_base, f"--base-frame {base_frame}")
    options = tests.Options(
        cycles=cycles,
        cube=_cube(cube),
        tool_mm=triple(tool, "--tool"),
        calibration=cal,
        calibration_path=calibration_path,
        registration=registration,
        cell=cells.read_cell(cell_file) if cell_file is not None else None,
        tracker_at_mm=triple(tracker_at, "--tracker-at"),
        seed=seed,
        run=RunOptions(readings=readings, **run_args.run_fields()),
    )
    # The simulated arm lands off its targets as a typical arm does, unless its URL
    # says otherwise (``--robot sim://?repeatability=none``).
    urls = _run.device_urls(robot, tracker, world_file=world_file, repeatability=True)
    devices = _run.devices(*urls, world_file=world_file, max_speed=run_args.max_speed)
    # The plan first: a cube out of reach is refused before any device is opened.
    if path_shape is not None:
        from calibrator.cli import verify_path

        verify_path.run(
            shape=path_shape,
            speed=verify_path.parse_speed(path_speed),
            arm=arm,
            cycles=cycles,
            options=options,
            devices=devices,
            output=output,
            inputs=inputs,
            yes=run_args.yes,
        )
    else:
        test = tests.prepare(arm, options, output, devices, settle_s=run_args.settle, inputs=inputs)
        summary = procedure.run(test, devices, Console(quiet=quiet, yes=run_args.yes))
        _report(summary, test, run_args.retries, output, data_path)
    if history is not None:
        from calibrator.cli.history import record

        record(history, "verification", output)


def _report(summary: Any, test: Any, retries: int, output: Path, data_path: Path) -> None:
    """The run's last lines: how it stopped (exit 1), else the figures."""
    hint = f"rerun the same command with --resume to continue ({summary.journal})"
    if summary.stopped:
        kept = f"{len(summary.measured)} of {summary.total} visits kept"
        typer.echo(f"stopped: {summary.stopped}; {kept}; {hint}", err=True)
        raise typer.Exit(1)
    if summary.failed:
        causes = f": {summary.causes_text()}" if summary.causes else ""
        typer.echo(
            f"{len(summary.failed)} visit(s) failed after {retries} retries{causes} "
            f"({summary.failed[:10]}); ISO 9283 needs every cycle: {hint} to retry them",
            err=True,
        )
        raise typer.Exit(1)
    if test.registration is None:
        typer.echo(
            "note: no --calibration, --register or --base-frame: the tracker is "
            "registered by a best fit on the test poses (AP is a lower bound)",
            err=True,
        )
    _print_table(test.doc, output, data_path)


def _base_frame(text: str | None) -> Any:
    """``X,Y,Z,RX,RY,RZ`` to base2tracker (4, 4), or None (exit 2 on values no cell has).

    The origin is a point in a robot cell (within the ``tracker_at`` budget, mm);
    the rotation vector's length is its angle, at most 2 pi rad.
    """
    if text is None:
        return None
    import numpy as np

    from calibrator.model import frames

    needs = "X,Y,Z,RX,RY,RZ (mm, rad)"
    values = np.array(opts.floats(text, 6, "--base-frame", needs))
    limit, unit = checks.BUDGETS["tracker_at"]
    if np.any(np.abs(values[:3]) > limit):
        fail(f"--base-frame: origin {values[:3].tolist()} {unit} is beyond +-{limit:g} {unit}")
    # Each component first: the norm of a 1e308 component overflows.
    if np.abs(values[3:]).max() > 2 * np.pi or np.linalg.norm(values[3:]) > 2 * np.pi:
        fail(
            f"--base-frame: rotation vector {values[3:].tolist()} is longer than 2 pi rad "
            "(its length is the angle)"
        )
    return frames.transform(rotations.rotvec_to_matrix(values[3:]), values[:3])


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
    if doc["orientation"].startswith("measured"):
        typer.echo("pose    APa deg   APb deg   APc deg   RPa deg   RPb deg   RPc deg")
        for p in doc["poses"]:
            values = "  ".join(f"{p[f'{f}{k}_deg']:8.5f}" for f in ("AP", "RP") for k in "abc")
            typer.echo(f"P{p['test_pose']}   {values}")
    else:
        typer.echo("orientation: " + doc["orientation"])
    typer.echo(f"wrote {output} and {data_path}")
