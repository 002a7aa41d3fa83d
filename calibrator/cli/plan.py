"""``calibrator plan``: joint configurations to measure, safe in the cell, observable, ordered."""

from __future__ import annotations

from enum import StrEnum
from pathlib import Path

import typer

from calibrator.cli import _checks as checks
from calibrator.cli import _options as opts
from calibrator.cli import _run
from calibrator.cli._app import app


class Sampling(StrEnum):
    halton = "halton"
    random = "random"


class Selection(StrEnum):
    d_optimal = "d-optimal"
    random = "random"
    first = "first"


@app.command()
@opts.urdf_links
def plan(
    output: Path = opts.output(Path("plan.csv"), "Plan CSV to write."),
    force: bool = opts.force(),
    model: str = opts.model(help="Named model (joint limits, kinematics, geometry)."),
    poses: int = typer.Option(
        40,  # 30 left 2.9 values per parameter after the hold-out: identify warned
        callback=checks.finite(1, 500),
        help="Poses in the plan (at most 500: over an hour of measuring).",
    ),
    candidates: int = typer.Option(
        None,
        callback=checks.finite(1, 1_000_000),
        help="Sampled candidates [default: from max(300 N, 6000), more until 4 N pass].",
    ),
    sampling: Sampling = typer.Option(Sampling.halton, help="How candidates are sampled."),
    joints: Path = typer.Option(
        None, "--from", help="CSV of candidate joint angles (q1_rad..q6_rad or q1_deg..q6_deg)."
    ),
    selection: Selection = typer.Option(
        Selection.d_optimal, help="How N poses are chosen among the feasible candidates."
    ),
    cell_file: Path = opts.cell(
        "Cell file (YAML): mounting plane, obstacles, tracker (docs/cell.md)."
    ),
    margin_deg: float = typer.Option(
        5.0, callback=checks.finite(0.0, 90.0), help="Stay this far inside joint limits, deg."
    ),
    tracker_at: str = opts.tracker_at(
        "Tracker position X,Y,Z in the robot base frame, mm (overrides the cell's)."
    ),
    acceptance_deg: float = typer.Option(
        None,
        callback=checks.finite(0.0, 90.0),
        help="Reflector acceptance half-angle, deg [default: the cell's, 30].",
    ),
    floor_mm: float = typer.Option(
        None,
        "--mounting-plane-mm",
        "--floor-mm",
        callback=checks.finite(-10000.0, 10000.0),
        help="z of the plane the robot stands on, base frame, mm [default: the cell's, "
        "else the model's]; every link keeps the cell's margin above it.",
    ),
    tool: str = opts.tool("Reflector position on the flange X,Y,Z, mm."),
    settle: float = typer.Option(
        0.5, callback=checks.finite(0.0, 3600.0), help="Settle per pose for the estimate, s."
    ),
    readings: int = typer.Option(
        10, callback=checks.finite(1, 100000), help="Readings per pose for the estimate."
    ),
    rate_hz: float = typer.Option(
        10.0,
        callback=checks.finite(0.0, 100000.0, inclusive=False),
        help="Tracker reading rate for the estimate, Hz.",
    ),
    # measure's own options and defaults: the estimate is the time measure will take.
    speed: float = _run.speed_option(0.5, "for the estimate: measure's --speed (default 0.5)"),
    accel: float = _run.accel_option(1.0, "for the estimate: measure's --accel (default 1.0)"),
    seed: int = opts.seed(0, "Seed of the random sampling and selection."),
) -> None:
    """Write a plan every pose and move of which is clear of the cell, in time-optimal order."""
    import dataclasses

    import numpy as np

    from calibrator import cell as cells
    from calibrator import outputs, planning
    from calibrator.cli._run import triple as _triple

    if joints is None and candidates is not None:
        checks.plan_work(poses, candidates, selection.value)
    if joints is not None:
        checks.file_rows("--from", joints, poses, selection.value)
    inputs = [p for p in (joints, cell_file) if p is not None]
    outputs.check(output, inputs=inputs, force=force)
    robot = _run.check_motion_caps(model, speed, accel, None)
    tool_mm = _triple(tool, "--tool")
    cell = cells.read_cell(cell_file) if cell_file is not None else cells.Cell()
    cell = cell.with_tracker(_triple(tracker_at, "--tracker-at"))
    assumed_tracker = cell.tracker_at_mm is None
    if assumed_tracker:
        # Every pose's aim is checked: without a position, at the simulated
        # cell's tracker (what measure's simulated tracker faces), said once written.
        from calibrator.simulate import SIM_TRACKER_AT_MM

        cell = cell.with_tracker(SIM_TRACKER_AT_MM)
    if acceptance_deg is not None:
        cell = dataclasses.replace(cell, acceptance_deg=acceptance_deg)
    if floor_mm is not None:
        cell = dataclasses.replace(cell, mounting_plane_z_mm=floor_mm)
    given = planning.read_csv(joints, robot) if joints is not None else None
    made = planning.make_checked(
        robot,
        poses,
        cell,
        tool_mm,
        margin_rad=np.radians(margin_deg),
        candidates=given,
        n_candidates=candidates,
        method=sampling.value,
        selection=selection.value,
        seed=seed,
        settle_s=settle,
        readings=readings,
        rate_hz=rate_hz,
        speed_rad_s=speed,
        accel_rad_s2=accel,
    )
    planning.write_plan(output, made.plan, inputs=inputs)
    lost = sum(made.dropped.values())
    counts = ", ".join(f"{reason} {k}" for reason, k in made.dropped.items() if k) or "none"
    typer.echo(f"candidates: {made.candidates}, dropped {lost} ({counts})")
    before, after = made.selection_time.total_s, made.ordered_time.total_s
    saving = f"saving {before - after:.0f} s ({100 * (before - after) / before:.0f} %)"
    typer.echo(
        f"estimated cell time {made.ordered_time} at {speed:g} rad/s, "
        f"{accel:g} rad/s^2 (measure's --speed, --accel); selection order "
        f"{made.selection_time.moves_s:.0f} s of moves, {saving}"
    )
    typer.echo(
        f"wrote {output}: {len(made.plan.q_rad)} poses"
        + (f" and {made.plan.n_vias} via rows" if made.plan.n_vias else "")
        + f", {selection.value} selection, "
        f"log det(J^T J) {planning.log_det(made.blocks):.2f}, "
        f"smallest singular value {planning.min_singular(made.blocks):.4g}"
    )
    if made.unjoined:
        typer.echo(
            f"note: replaced {made.unjoined} chosen pose(s) that no safe move joined to the "
            "others (directly, in any order tried, or through the arm held upright) by the "
            f"next best candidates of the {selection.value} selection",
            err=True,
        )
    guessed = made.plan.origin.guessed_geometry if made.plan.origin is not None else None
    if guessed:
        # Collisions were checked against capsules guessed from the joints, not the arm's shape.
        typer.echo(
            f"warning: guessed geometry: {guessed}; every pose and move was checked against "
            "these guessed capsules, not the arm's housings (the plan file says so too): give "
            "the meshes (ROS_PACKAGE_PATH, or beside the URDF's package) for a plan checked "
            "against its shape",
            err=True,
        )
    for line in robot.limit_notes:
        # Limits narrowed from the description's source: the plan keeps within these.
        typer.echo(f"note: {line}", err=True)
    if assumed_tracker:
        typer.echo(
            "note: no --tracker-at and no tracker in the cell: the poses face the simulated "
            f"cell's tracker at {planning.point_text(SIM_TRACKER_AT_MM)} mm",
            err=True,
        )
