"""``calibrator simulate``: a session measured on a simulated arm, pure numpy (no wire)."""

import json
from enum import StrEnum
from pathlib import Path

import typer

from calibrator.cli._app import app
from calibrator.errors import CalibrationError


class Frame(StrEnum):
    base = "base"
    tracker = "tracker"


class Errors(StrEnum):
    seed = "seed"
    random = "random"
    none = "none"


@app.command()
def simulate(
    output: Path = typer.Option(
        Path("session.parquet"), "-o", "--output", help="Session to write."
    ),
    model: str = typer.Option("er10l-c10", help="Named nominal model."),
    poses: int = typer.Option(32, min=1, help="Number of poses."),
    seed: int = typer.Option(3, help="Seed of every random draw."),
    frame: Frame = typer.Option(Frame.base, help="Frame of the recorded points."),
    orientation: bool = typer.Option(True, help="Record probe orientation (6-DoF probe)."),
    noise_mm: float = typer.Option(0.02, min=0.0, help="RMS 3-D error of a recorded point (mm)."),
    orientation_noise_deg: float = typer.Option(
        0.005, min=0.0, help="RMS orientation error (deg)."
    ),
    joint_noise_rad: float = typer.Option(0.0, min=0.0, help="Encoder noise per joint (rad)."),
    errors: Errors = typer.Option(
        None, help="True MDH errors [default: seed for er10l-c10, else random]."
    ),
    tool_offset_mm: float = typer.Option(
        0.0, min=0.0, help="Unknown tool offset (mm); 0 = tool known."
    ),
):
    """Write a session measured on a simulated arm, and its truth beside it."""
    import numpy as np

    from calibrator import session
    from calibrator import simulate as sim

    errors_value = (
        errors.value if errors else ("seed" if model.lower() == "er10l-c10" else "random")
    )
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
        )
    except ValueError as exc:
        raise CalibrationError(str(exc)) from None
    session.write(output, table, meta)
    truth_path = output.with_suffix(".truth.json")
    truth_path.write_text(json.dumps(truth.to_json(), indent=2) + "\n")
    typer.echo(
        f"wrote {output} ({poses} poses, model {meta.model}, frame {frame.value}) and {truth_path}"
    )
