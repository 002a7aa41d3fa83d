"""``calibrator``: the command line. Thin: parses flags, calls the domain, prints.

Every domain error becomes one line on stderr and exit code 2. Heavy
modules are imported inside the commands so ``--help`` stays quick.
"""

import json
import sys
import time
from enum import StrEnum
from pathlib import Path

import typer

from calibrator.errors import CalibrationError

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,
    help="Calibrate 6-axis robot arms with a laser tracker in the loop.",
)


class Method(StrEnum):
    hybrid = "hybrid"
    pso = "pso"
    lm = "lm"


class Frame(StrEnum):
    base = "base"
    tracker = "tracker"


class Errors(StrEnum):
    seed = "seed"
    random = "random"
    none = "none"


class ExportFormat(StrEnum):
    json = "json"
    csv = "csv"


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


@app.command()
def identify(
    session_path: Path = typer.Argument(..., metavar="SESSION", help="Session file (Parquet)."),
    output: Path = typer.Option(Path("calibration.json"), "-o", "--output"),
    model: str = typer.Option(None, help="Named model instead of the session's."),
    method: Method = typer.Option(Method.hybrid),
    particles: int = typer.Option(20, min=2),
    generations: int = typer.Option(2000, min=0),
    k: float = typer.Option(None, "--k", help="Orientation weight (mm^2/rad^2) [default: 1e4]."),
    validation_fraction: float = typer.Option(
        0.2, min=0.0, max=0.95, help="Share of poses held out (0 = fit all)."
    ),
    seed: int = typer.Option(0),
    tool_known: bool = typer.Option(
        None, "--tool-known/--tool-free", help="Fix or identify the tool point [default: session]."
    ),
):
    """Identify MDH parameters from a session and write calibration.json."""
    from calibrator import calibration, session
    from calibrator.identify import pipeline, report

    started = time.perf_counter()
    loaded = session.load(session_path, model=model)
    options = pipeline.Options(
        method=method.value,
        particles=particles,
        generations=generations,
        k=k,
        validation_fraction=validation_fraction,
        seed=seed,
        tool_known=tool_known,
    )
    result = pipeline.identify(loaded, options)
    doc = calibration.to_json(result, session_path, loaded.meta.model)
    calibration.write(output, doc)
    typer.echo(
        f"{len(result.fit_index)} fitted and {len(result.validation_index)} held-out poses, "
        f"{result.space.size} free parameters, method {method.value}"
    )
    for item in result.dropped:
        typer.echo(f"  not identified: {item['name']:8s} {item['reason']}")
    typer.echo(report.format_table(result.stats))
    typer.echo(f"wrote {output} in {time.perf_counter() - started:.2f} s")


@app.command("export-params")
def export_params(
    calibration_path: Path = typer.Argument(..., metavar="CALIBRATION"),
    fmt: ExportFormat = typer.Option(ExportFormat.json, "--format"),
    output: Path = typer.Option(None, "-o", "--output", help="File to write [default: stdout]."),
):
    """Write the compensated parameters in a format robot users load."""
    from calibrator import calibration, export

    text = export.export(calibration.load(calibration_path), fmt.value)
    if output is None:
        sys.stdout.write(text)
    else:
        output.write_text(text)
        typer.echo(f"wrote {output}")


def main(argv=None):
    """Console entry point: run the app, turning known errors into one line."""
    try:
        app(args=argv, prog_name="calibrator")
    except CalibrationError as exc:
        typer.echo(f"calibrator: error: {exc}", err=True)
        sys.exit(2)
    except OSError as exc:
        typer.echo(
            f"calibrator: error: {exc.strerror or exc}: {exc.filename or ''}".rstrip(": "), err=True
        )
        sys.exit(2)


if __name__ == "__main__":
    main()
