"""``calibrator export-params``: the calibrated model in the formats robots and planners read."""

import sys
from enum import StrEnum
from pathlib import Path

import typer

from calibrator.cli import _model
from calibrator.cli import _options as opts
from calibrator.cli._app import app
from calibrator.export import REGISTRY

#: The ``--format`` choices, generated from the exporter registry.
# mypy cannot type a functional Enum whose members come from a registry at run time.
ExportFormat = StrEnum("ExportFormat", {name: name for name in REGISTRY})  # type: ignore[misc]
_FORMAT_HELP = "Output format [default: from the output's extension, else json]. " + "; ".join(
    f"{f.name}: {f.help}" for f in REGISTRY.values()
)


@app.command("export-params")
def export_params(
    calibration_path: Path = typer.Argument(
        ..., metavar="CALIBRATION", help="Calibration file (JSON) written by identify."
    ),
    fmt: ExportFormat = typer.Option(None, "--format", help=_FORMAT_HELP),
    output: Path = opts.output(None, "File to write [default: stdout]."),
    force: bool = opts.force(),
    like: Path = typer.Option(
        None,
        "--like",
        help="With --format urdf: write this URDF back with only its chain's joint origins "
        "calibrated (the URDF identify's --model named).",
    ),
    base_link: str = typer.Option(
        None, "--base-link", help="With --like: the chain's base link [default: the arm's]."
    ),
    tip_link: str = typer.Option(
        None, "--tip-link", help="With --like: the chain's tip link [default: the arm's]."
    ),
    model: str = opts.model(
        None,
        "Named model of a calibration that names none (joint names and limits, UR's table) "
        "[default: the calibration's]; a calibration's arm cannot be changed.",
    ),
) -> None:
    """Write the calibrated model in a format robot users load."""
    from calibrator import calibration, export, outputs
    from calibrator.errors import CalibrationError

    name = export.choose(None if fmt is None else fmt.value, output)
    inputs = [calibration_path] + ([like] if like is not None else [])
    if like is None and (base_link or tip_link):
        raise CalibrationError("--base-link and --tip-link go with --like")
    if like is not None and name != "urdf":
        raise CalibrationError(f"--like writes a URDF, not {name}")
    if output is not None:
        outputs.check(output, inputs=inputs, force=force)
    cal = _model.calibration(calibration.load(calibration_path), calibration_path, model)
    if like is not None:
        result = export.export_like(cal, like, base_link, tip_link)
    else:
        result = export.export(cal, name)
    for note in result.notes:
        typer.echo(f"note: {note}", err=True)
    if output is None:
        sys.stdout.write(result.text)
        return
    outputs.write_text(output, result.text, inputs=inputs)
    typer.echo(f"wrote {output} ({name})")
