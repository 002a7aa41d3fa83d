"""``calibrator identify``: MDH parameters from a session, written to calibration.json."""

import time
from enum import StrEnum
from pathlib import Path

import typer

from calibrator.cli._app import app


class Method(StrEnum):
    hybrid = "hybrid"
    pso = "pso"
    lm = "lm"


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
    nominal_file: Path = typer.Option(
        None,
        "--nominal",
        help="Start from a factory calibration: UR DH deltas or a ROS kinematics YAML.",
    ),
):
    """Identify MDH parameters from a session and write calibration.json."""
    from calibrator import calibration, session
    from calibrator.identify import pipeline, report

    started = time.perf_counter()
    loaded = session.load(session_path, model=model)
    if nominal_file is not None:
        from calibrator import nominal

        typer.echo(nominal.apply(loaded.meta, nominal_file))
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
    calibration.Calibration.from_result(
        result, session_path, loaded.meta.model, loaded.meta.frame
    ).save(output)
    typer.echo(
        f"{len(result.fit_index)} fitted and {len(result.validation_index)} held-out poses, "
        f"{result.space.size} free parameters, method {method.value}"
    )
    for item in result.dropped:
        typer.echo(f"  not identified: {item['name']:8s} {item['reason']}")
    typer.echo(report.format_table(result.stats))
    typer.echo(f"wrote {output} in {time.perf_counter() - started:.2f} s")
