"""``calibrator plan``: joint configurations to measure, fit for the cell and observability."""

from __future__ import annotations

from enum import StrEnum
from pathlib import Path

import typer

from calibrator.cli import _checks as checks
from calibrator.cli._app import app


class Sampling(StrEnum):
    halton = "halton"
    random = "random"


class Selection(StrEnum):
    d_optimal = "d-optimal"
    random = "random"
    first = "first"


@app.command()
def plan(
    output: Path = typer.Option(Path("plan.csv"), "-o", "--output", help="Plan CSV to write."),
    model: str = typer.Option("ur10e", help="Named model (joint limits, kinematics)."),
    poses: int = typer.Option(30, callback=checks.count("plan_poses"), help="Poses in the plan."),
    candidates: int = typer.Option(
        None,
        callback=checks.count("candidates"),
        help="Sampled candidates [default: max(60 N, 2000)].",
    ),
    sampling: Sampling = typer.Option(Sampling.halton, help="How candidates are sampled."),
    joints: Path = typer.Option(
        None, "--from", help="CSV of candidate joint angles (q1_rad..q6_rad or q1_deg..q6_deg)."
    ),
    selection: Selection = typer.Option(
        Selection.d_optimal, help="How N poses are chosen among the feasible candidates."
    ),
    margin_deg: float = typer.Option(
        5.0, callback=checks.finite(minimum=0.0), help="Stay this far inside joint limits, deg."
    ),
    tracker_at: str = typer.Option(
        None,
        callback=checks.point_mm("tracker_at"),
        help="Tracker position X,Y,Z in the robot base frame, mm (acceptance check).",
    ),
    acceptance_deg: float = typer.Option(
        30.0, callback=checks.finite(0.0, 90.0), help="Reflector acceptance half-angle, deg."
    ),
    floor_mm: float = typer.Option(
        0.0, callback=checks.finite(), help="Lowest z of tool and wrist in the base frame, mm."
    ),
    tool: str = typer.Option(
        "0,0,100",
        callback=checks.point_mm("tool"),
        help="Reflector position on the flange X,Y,Z, mm.",
    ),
    seed: int = typer.Option(
        0, callback=checks.seed(), help="Seed of the random sampling and selection."
    ),
):
    """Write a plan of joint configurations inside limits, facing the tracker, above the floor."""
    import numpy as np

    from calibrator import frames, outputs
    from calibrator import plan as plans
    from calibrator.cli.measure import _triple
    from calibrator.models import get_model

    if joints is None:
        checks.plan_work(poses, candidates, selection.value)
    inputs = [] if joints is None else [joints]
    outputs.check(output, inputs=inputs)
    robot = get_model(model)
    at = _triple(tracker_at, "--tracker-at")
    cell = plans.CellConstraints(
        margin_rad=np.radians(margin_deg),
        tracker_at_mm=None if at is None else np.array(at),
        acceptance_rad=np.radians(acceptance_deg),
        floor_mm=floor_mm,
        flange2tool=frames.transform(translation=_triple(tool, "--tool")),
    )
    given = plans.read_csv(joints) if joints is not None else None
    q = plans.make(
        robot.mdh,
        robot.joint_limits_rad,
        poses,
        cell,
        candidates=given,
        n_candidates=candidates,
        method=sampling.value,
        selection=selection.value,
        seed=seed,
    )
    blocks = plans.observability(robot.mdh, q, cell.flange2tool).blocks
    plans.write_csv(output, q, inputs=inputs)
    typer.echo(
        f"wrote {output}: {len(q)} poses, {selection.value} selection, "
        f"log det(J^T J) {plans.log_det(blocks):.2f}, "
        f"smallest singular value {plans.min_singular(blocks):.4g}"
        + ("" if at is not None else " (no --tracker-at: acceptance angle not checked)")
    )
