"""``calibrator simulate``: a session measured on a simulated arm, pure numpy (no wire)."""

import json
from enum import StrEnum
from pathlib import Path

import typer

from calibrator.cli import _checks as checks
from calibrator.cli import _options as opts
from calibrator.cli._app import app
from calibrator.cli._options import fail
from calibrator.errors import CalibrationError
from calibrator.robots import ipso_paper


class Frame(StrEnum):
    base = "base"
    tracker = "tracker"


#: Values of ``--errors``; "seed" is the old name of "ref003", still accepted.
ERRORS = ("ref003", "random", "none")


def _errors_choice(value: str | None):
    if value is None or value in ERRORS:
        return value
    if value == "seed":
        return "ref003"
    raise typer.BadParameter(f"must be one of {', '.join(ERRORS)}, got {value!r}")


def _has_reference_errors(model: str) -> bool:
    """Whether the arm's description carries a paper's table of true errors."""
    from calibrator import robots

    try:
        return robots.get(model).reference_errors is not None
    except CalibrationError:
        return False  # sim.simulate names the unknown model


@app.command()
@opts.urdf_links
def simulate(
    output: Path = opts.output(
        Path("session.parquet"),
        "Session to write (Parquet); its truth goes beside it as NAME.truth.json.",
    ),
    force: bool = opts.force(),
    model: str = opts.model(ipso_paper.NAME, "Named nominal model."),
    poses: int = typer.Option(
        32, callback=checks.count("simulate_poses"), help="Number of poses (>= 1)."
    ),
    seed: int = opts.seed(3, "Seed of every random draw."),
    frame: Frame = typer.Option(Frame.base, help="Frame of the recorded points."),
    orientation: bool = typer.Option(True, help="Record probe orientation (6-DoF probe)."),
    noise_mm: float = typer.Option(
        0.02,
        callback=checks.finite(0.0, checks.BUDGETS["noise_mm"][0]),
        help="RMS 3-D error of a recorded point (mm).",
    ),
    orientation_noise_deg: float = typer.Option(
        0.005,
        callback=checks.finite(0.0, checks.BUDGETS["noise_deg"][0]),
        help="RMS orientation error (deg).",
    ),
    joint_noise_rad: float = typer.Option(
        0.0,
        callback=checks.finite(0.0, checks.BUDGETS["noise_rad"][0]),
        help="Encoder noise per joint (rad).",
    ),
    errors: str = typer.Option(
        None,
        metavar="ref003|random|none",
        callback=_errors_choice,
        help=f"True MDH errors: ref003 = Table 2 of the IPSO paper ({ipso_paper.NAME} only), "
        f"random, or none [default: ref003 for {ipso_paper.NAME}, else random].",
    ),
    tool_offset_mm: float = typer.Option(
        0.0,
        callback=checks.finite(0.0, checks.BUDGETS["tool"][0]),
        help="Unknown tool offset (mm); 0 = tool known.",
    ),
    measured_at: str = typer.Option(
        None,
        "--measured-at",
        metavar="ISO8601",
        help="Date the session as measured then (its poses' timestamps, 10 s apart; a time "
        "without zone is UTC) [default: no timestamps].",
    ),
) -> None:
    """Write a session measured on a simulated arm, and its truth beside it."""
    import numpy as np

    from calibrator import outputs, session
    from calibrator import simulate as sim

    when = None
    if measured_at is not None:
        from datetime import datetime

        try:
            when = datetime.fromisoformat(measured_at)
        except ValueError:
            fail(f"--measured-at {measured_at!r}: give an ISO 8601 time, e.g. 2026-03-01T08:00:00Z")
    outputs.check(output, force=force)
    truth_path = outputs.check(output.with_suffix(".truth.json"), force=force)
    errors_value = errors or ("ref003" if _has_reference_errors(model) else "random")
    try:
        table, meta, truth = sim.simulate(
            model=model,
            poses=poses,
            seed=seed,
            frame=frame.value,
            orientation=orientation,
            noise_mm=noise_mm,
            orientation_noise_rad=np.radians(orientation_noise_deg),
            joint_noise_rad=joint_noise_rad,
            errors=errors_value,
            tool_offset_mm=tool_offset_mm,
            measured_at=when,
        )
    except ValueError as exc:
        raise CalibrationError(str(exc)) from None
    with outputs.Outputs() as batch:  # both files or neither
        session.write(output, table, meta, batch=batch)
        batch.text(truth_path, json.dumps(truth.to_json(), indent=2) + "\n")
    typer.echo(
        f"wrote {output} ({poses} pose{'' if poses == 1 else 's'}, model {meta.model}, "
        f"frame {frame.value}) and {truth_path}"
    )
