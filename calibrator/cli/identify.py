"""``calibrator identify``: MDH parameters from a session, written to calibration.json."""

import sys
import time
from enum import StrEnum
from pathlib import Path

import typer

from calibrator.cli._app import app


class Method(StrEnum):
    hybrid = "hybrid"
    pso = "pso"
    lm = "lm"


class Loss(StrEnum):
    lsq = "lsq"
    huber = "huber"
    trimmed = "trimmed"
    minimax = "minimax"


@app.command()
def identify(
    session_path: Path = typer.Argument(..., metavar="SESSION", help="Session file (Parquet)."),
    output: Path = typer.Option(Path("calibration.json"), "-o", "--output"),
    model: str = typer.Option(None, help="Named model instead of the session's."),
    method: Method = typer.Option(Method.hybrid),
    loss: Loss = typer.Option(
        Loss.lsq,
        help="lsq: least squares; huber/trimmed: robust to outlier poses; "
        "minimax: smallest worst-pose error.",
    ),
    particles: int = typer.Option(20, min=2),
    generations: int = typer.Option(2000, min=0),
    k: float = typer.Option(None, "--k", help="Orientation weight (mm^2/rad^2) [default: 1e4]."),
    validation_fraction: float = typer.Option(
        0.2, min=0.0, max=0.95, help="Share of poses held out (0 = fit all)."
    ),
    seed: int = typer.Option(0),
    noise_mm: float = typer.Option(
        0.05, min=1e-9, help="Measurement noise assumed when deciding what the poses identify."
    ),
    tool_known: bool = typer.Option(
        None,
        "--tool-known/--tool-free",
        help="Fix or identify the tool frame (point; rotation with 6-DoF data) [default: session].",
    ),
    nominal_file: Path = typer.Option(
        None,
        "--nominal",
        help="Start from a factory calibration: UR DH deltas or a ROS kinematics YAML.",
    ),
):
    """Identify MDH parameters from a session and write calibration.json."""
    from calibrator import calibration, session
    from calibrator.identify import pipeline, report, uncertainty

    started = time.perf_counter()
    # Progress goes to a terminal only: piped stderr stays one line on errors.
    show = sys.stderr.isatty()
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
        loss=loss.value,
        noise_mm=noise_mm,
        on_generation=_generation_printer(generations) if show else None,
        progress=(lambda text: typer.echo(f"... {text}", err=True)) if show else None,
    )
    result = pipeline.identify(loaded, options)
    calibration.Calibration.from_result(
        result, session_path, loaded.meta.model, loaded.meta.frame
    ).save(output)
    typer.echo(
        f"{len(result.fit_index)} fitted and {len(result.validation_index)} held-out poses, "
        f"{result.space.size} free parameters, method {method.value}, loss {loss.value}"
    )
    for item in result.dropped:
        typer.echo(f"  not identified: {item['name']:8s} {item['reason']}")
    for text in result.warnings:
        typer.echo(f"warning: {text}")
    if result.outliers and loss.value in ("huber", "trimmed"):
        typer.echo(f"outlier poses set aside: {', '.join(map(str, result.outliers))}")
    typer.echo(report.format_table(result.stats))
    for line in uncertainty.summary_lines(result.uncertainty):
        typer.echo(line)
    typer.echo(f"wrote {output} in {time.perf_counter() - started:.2f} s")


def _generation_printer(generations):
    """Report the swarm's progress at every tenth of its generations."""
    step = max(generations // 10, 1)

    def show(generation, best_cost):
        if generation % step == 0 or generation == generations:
            typer.echo(
                f"... swarm generation {generation}/{generations}: {best_cost:.6g}", err=True
            )

    return show
