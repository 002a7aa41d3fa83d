"""``calibrator program``: the plan as a robot program for any controller (``--robot external``).

With ``--path`` it writes the ISO 9283 path test instead (:mod:`calibrator.cli.program_path`).
"""

from __future__ import annotations

from enum import StrEnum
from pathlib import Path
from typing import Any

import typer

from calibrator.cli import _checks as checks
from calibrator.cli import _model, _run
from calibrator.cli import _options as opts
from calibrator.cli._app import app
from calibrator.cli._options import fail
from calibrator.languages.registry import writers
from calibrator.languages.spec import MAX_DWELL_S, MIN_ACCEL_RAD_S2, MIN_SPEED_RAD_S, PULSE_S

#: The ``--format`` choices, generated from the languages' writers.
# mypy cannot type a functional Enum whose members come from a registry at run time.
ProgramFormat = StrEnum("ProgramFormat", {name: name for name in writers()})  # type: ignore[misc]
_FORMAT_HELP = "Program language [default: from the output's extension]. " + "; ".join(
    f"{f.name}: {f.help}" for f in writers().values()
)


class Targets(StrEnum):
    """``--targets``: what a move states (docs/external-robots.md)."""

    joints = "joints"
    cartesian = "cartesian"


#: The languages that write Cartesian targets.
CARTESIAN = ("urscript",)


@app.command()
@opts.urdf_links
def program(
    plan_path: Path = typer.Argument(
        None, metavar="[PLAN]", help="Plan CSV (calibrator plan); none with --path."
    ),
    output: Path = opts.output(..., "Program file to write."),
    force: bool = opts.force(),
    fmt: ProgramFormat = typer.Option(None, "--format", help=_FORMAT_HELP),
    model: str = opts.model(
        None,
        "Named model (joint limits, speed ceiling) [default: the plan's, else ur10e]; "
        "a plan's arm cannot be changed.",
    ),
    speed: float = _run.speed_option(None, "[default: the model's fixed ceiling; only lower]"),
    accel: float = _run.accel_option(None, "[default: the model's ceiling; only lower]"),
    dwell: float = typer.Option(
        2.0,
        callback=checks.finite(PULSE_S, MAX_DWELL_S, inclusive=False),
        help="Wait at each pose, s: more than the settle window plus the readings' time "
        f"(at most {MAX_DWELL_S:g}); with --path the hold at the path's ends (at least 0.5).",
    ),
    pulse: int = typer.Option(
        None,
        callback=checks.count("pulse", 0),
        help="Digital output pulsed at each arrival (URScript 0-7, KRL and Fanuc from 1).",
    ),
    home: str = typer.Option(
        None,
        help="Safe start and end pose J1,...,J6 in degrees [default: the plan's first pose].",
    ),
    cell_file: Path = opts.cell(
        "Cell file (YAML, docs/cell.md): mounting plane, obstacles, tracker; every pose "
        "and move of the program, from and back to home included, is checked against it."
    ),
    tracker_at: str = opts.tracker_at(
        "Tracker position in the robot base frame X,Y,Z (mm; overrides the cell's): the "
        "poses' aim and line of sight are checked only when it is known."
    ),
    tool: str = opts.tool(
        "Reflector position on the flange X,Y,Z, mm [default: the plan file's, else 0,0,100].",
        default=None,
    ),
    targets: Targets = typer.Option(
        "joints",
        "--targets",
        help="joints: every move to joint angles; cartesian: each pose's move to the flange "
        "pose the nominal model gives there (URScript p[...]; home and vias stay joints), "
        "targets `calibrator compensate` corrects.",
    ),
    path_shape: str = typer.Option(
        None,
        "--path",
        metavar="line|circle|rectangle",
        help="Write the ISO 9283 path test instead of a plan: the line, circle or rectangle "
        "`calibrator verify --path` commands with the same --cube, --tool, --tracker-at and "
        "--cell, as straight and circular moves at --path-speed, --cycles times, holding "
        "--dwell s at its ends; run it while `verify --path --robot external` streams "
        "(docs/verify.md).",
    ),
    path_speed: str = typer.Option(
        None,
        "--path-speed",
        metavar="MM_S|PCT%",
        help="--path: tool speed along the path, mm/s, or a percentage of its rated speed "
        "(written as whole mm/s; give verify the mm/s the command prints) [default: 100].",
    ),
    cycles: int = typer.Option(
        None,
        callback=checks.count("cycles", 1),
        help="--path: runs of the path [default: 30, as verify's].",
    ),
    cube: str = typer.Option(
        None,
        help="--path: test cube X,Y,Z,SIDE, mm, in the controller's base frame "
        "[default: the largest that fits, as verify's].",
    ),
    calibration_path: Path = typer.Option(
        None,
        "--calibration",
        help="--path: compensate the path's targets with this calibration (the path "
        "`verify --path --calibration` commands; written as short blended moves).",
    ),
) -> None:
    """Write the plan as a robot program: home, a joint move and a dwell per pose, home.

    Via rows of the plan become joint moves without dwell or pulse before their pose.
    The program is the only gate for an arm the controller runs on its own, so it
    runs the whole-plan check of ``measure`` first and writes nothing it refuses.
    With --path (no PLAN) it writes the ISO 9283 path test instead, for
    ``verify --path --robot external`` (docs/verify.md).
    """
    import numpy as np

    from calibrator import cell as cells
    from calibrator import outputs, planning, robots
    from calibrator.languages import writing as programs

    chosen = programs.choose(None if fmt is None else fmt.value, output)
    if path_shape is not None:
        _refuse_with_path(plan_path, pulse, home, targets)
        _write_path(
            path_shape,
            "100" if path_speed is None else path_speed,
            30 if cycles is None else cycles,
            cube,
            chosen,
            output,
            force,
            model,
            speed,
            accel,
            dwell,
            cell_file,
            tracker_at,
            tool,
            calibration_path,
        )
        return
    given = {"--path-speed": path_speed, "--cycles": cycles, "--cube": cube}
    given["--calibration"] = calibration_path
    for flag, value in given.items():
        if value is not None:
            why = " (correct a plan's program with calibrator compensate)"
            fail(f"{flag} is for --path" + (why if flag == "--calibration" else ""))
    if plan_path is None:
        fail("give a PLAN (a plan CSV), or --path line|circle|rectangle")
    if targets == Targets.cartesian and chosen not in CARTESIAN:
        fail(f"--targets cartesian is written in {', '.join(CARTESIAN)} only, not {chosen}")
    # KRL and Fanuc want the program named as its file; no language takes a keyword.
    name = programs.name_for(chosen, output)
    inputs = [p for p in (plan_path, cell_file) if p is not None]
    outputs.check(output, inputs=inputs, force=force)
    given = planning.read_plan(plan_path)
    # The plan's arm; --model only for a plan that names none.
    origin = given.origin
    arm = robots.get(
        _model.resolve(model, _model.From(None if origin is None else origin.model, plan_path))
    )
    if origin is None:
        # A plan naming no arm holds the controller's angles of the arm just resolved.
        given = planning.read_plan(plan_path, arm)
    speed = arm.move_speed_cap_rad_s if speed is None else speed
    accel = arm.move_accel_cap_rad_s2 if accel is None else accel
    if speed > arm.move_speed_cap_rad_s:
        fail(f"--speed {speed} rad/s above the {arm.name} ceiling {arm.move_speed_cap_rad_s}")
    if accel > arm.move_accel_cap_rad_s2:
        fail(f"--accel {accel} rad/s^2 above the {arm.name} ceiling {arm.move_accel_cap_rad_s2}")
    # Slower than this is a typo, and a program never rounds a speed to zero.
    if speed < MIN_SPEED_RAD_S:
        fail(f"--speed {speed:g} rad/s below {MIN_SPEED_RAD_S:g} rad/s (a 1 rad move: 17 min)")
    if accel < MIN_ACCEL_RAD_S2:
        fail(f"--accel {accel:g} rad/s^2 below {MIN_ACCEL_RAD_S2:g} rad/s^2")
    # --home is J1..J6 as the pendant shows them: the controller's angles.
    home_rad = (
        given.q_rad[0] if home is None else arm.convention.to_model(np.radians(_degrees(home)))
    )
    cell = cells.read_cell(cell_file) if cell_file is not None else cells.Cell()
    cell = cell.with_tracker(_run.triple(tracker_at, "--tracker-at"))
    # A plan made for another arm, tracker or reflector is refused; what the
    # command line leaves out comes from the plan file.
    tracker_mm, tool_mm = planning.made_for(
        given, arm, cell.tracker_at_mm, _run.triple(tool, "--tool"), plan_path
    )
    cell = cell.with_tracker(tracker_mm)
    # What measure --robot external would refuse is refused here, before a
    # program exists: the controller runs it without asking calibrator again.
    planning.check_plan(
        given,
        arm,
        cell,
        tool_mm,
        home_rad=home_rad,
        need=planning.min_poses(arm.mdh),
    )
    q = given.q_rad
    spec = programs.ProgramSpec(
        plan_rad=q,
        home_rad=home_rad,
        speed_rad_s=speed,
        accel_rad_s2=accel,
        max_joint_speed_rad_s=arm.max_joint_speed_rad_s,
        dwell_s=dwell,
        pulse_output=pulse,
        name=name,
        model=arm.name,
        via_rad=given.via_rad,
        joint_limits_rad=arm.joint_limits_rad,
        convention=arm.convention,
        targets=targets.value,
        mdh=arm.mdh,
    )
    outputs.write_text(output, programs.render(spec, chosen), inputs=inputs)
    if cell.tracker_at_mm is None:
        typer.echo(
            "note: no --tracker-at and no tracker in the cell: the poses' aim and line of "
            "sight were not checked",
            err=True,
        )
    typer.echo(
        f"wrote {output} ({chosen}): {len(q)} poses"
        + (f" and {given.n_vias} vias" if given.n_vias else "")
        + f", {speed:g} rad/s, {dwell:g} s dwell; "
        f"measure with --robot external --plan {plan_path}"
    )


def _degrees(text: str) -> list[float]:
    """``--home J1,...,J6`` (deg) to six finite floats (exit 2 otherwise)."""
    return opts.floats(text, 6, "--home", "six joint angles J1,...,J6 in degrees")


def _refuse_with_path(plan_path: Path | None, pulse: Any, home: Any, targets: Any) -> None:
    """``--path`` writes the path test, not a plan: what belongs to a plan is refused."""
    if plan_path is not None:
        fail(f"--path writes the ISO 9283 path, not a plan: leave out {plan_path}")
    for given, flag in ((pulse, "--pulse"), (home, "--home")):
        if given is not None:
            fail(f"{flag} is for plan programs, not --path")
    if targets != Targets.joints:
        fail("--targets is for plan programs (a path program's moves are Cartesian)")


def _write_path(
    shape: str,
    path_speed: str,
    cycles: int,
    cube: str | None,
    chosen: str,
    output: Path,
    force: bool,
    model: str | None,
    speed: float | None,
    accel: float | None,
    dwell: float,
    cell_file: Path | None,
    tracker_at: str | None,
    tool: str | None,
    calibration_path: Path | None,
) -> None:
    """``program --path``: the path test as a program (:mod:`calibrator.cli.program_path`)."""
    from calibrator import cell as cells
    from calibrator import outputs, robots
    from calibrator.cli import program_path, verify_path
    from calibrator.cli.verify import _cube
    from calibrator.errors import CalibrationError
    from calibrator.languages import writing as programs
    from calibrator.verify.path import SHAPES
    from calibrator.verify.path_external import MIN_HOLD_S

    if shape not in SHAPES:
        fail(f"--path must be one of {', '.join(SHAPES)}, got {shape!r}")
    if chosen not in ("urscript", "krl", "rapid", "fanuc-ls"):
        fail(f"--path is written in urscript, krl, rapid and fanuc-ls, not {chosen}")
    if dwell < MIN_HOLD_S:
        fail(
            f"--dwell {dwell:g} s: a path program holds at least {MIN_HOLD_S:g} s at the path's "
            "ends (verify --path tells the cycles apart by those rests)"
        )
    request_speed = verify_path.parse_speed(path_speed)
    if not request_speed.percent and not (1.0 <= request_speed.value <= 5000.0):
        fail(f"--path-speed must be in [1, 5000] mm/s, got {request_speed.value:g}")
    name = programs.name_for(chosen, output)
    inputs = [p for p in (cell_file, calibration_path) if p is not None]
    outputs.check(output, inputs=inputs, force=force)
    cal = None
    recorded = []
    if calibration_path is not None:
        from calibrator import calibration as calibrations

        cal = calibrations.load(calibration_path)
        # The calibration's arm; --model only for one that names none.
        recorded.append(_model.From(cal.model, calibration_path))
    arm = robots.get(_model.resolve(model, *recorded))
    speed = arm.move_speed_cap_rad_s if speed is None else speed
    accel = arm.move_accel_cap_rad_s2 if accel is None else accel
    if speed > arm.move_speed_cap_rad_s:
        fail(f"--speed {speed} rad/s above the {arm.name} ceiling {arm.move_speed_cap_rad_s}")
    if accel > arm.move_accel_cap_rad_s2:
        fail(f"--accel {accel} rad/s^2 above the {arm.name} ceiling {arm.move_accel_cap_rad_s2}")
    cell = cells.read_cell(cell_file) if cell_file is not None else None
    tracker_mm = _run.triple(tracker_at, "--tracker-at")
    if tracker_mm is None and cell is not None:
        tracker_mm = cell.tracker_at_mm
    request = program_path.PathRequest(
        shape=shape,
        speed=request_speed,
        cycles=cycles,
        hold_s=dwell,
        cube=_cube(cube),
        tool_mm=_run.triple(tool, "--tool"),
        tracker_at_mm=tracker_mm,
        cell=cell,
        calibration=cal,
    )
    try:
        spec, mm_s, rated = program_path.path_spec(
            arm,
            request,
            name=name,
            speed_rad_s=speed,
            accel_rad_s2=accel,
            fanuc=chosen == "fanuc-ls",
        )
        text = programs.render_path(spec, chosen)
    except CalibrationError as exc:
        fail(str(exc))
    outputs.write_text(output, text, inputs=inputs)
    state = "compensated" if cal is not None else "nominal"
    register = f"--calibration {calibration_path}" if cal is not None else "--register CAL"
    typer.echo(
        f"wrote {output} ({chosen}): ISO 9283 {shape} path ({state}), {cycles} cycles at "
        f"{mm_s:g} mm/s "
        f"({100.0 * mm_s / rated:.0f} % of its rated {rated:.0f} mm/s), {dwell:g} s holds; "
        f"measure it with verify --path {shape} --path-speed {mm_s:g} --cycles {cycles} "
        f"--robot external {register}"
    )
