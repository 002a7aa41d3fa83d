"""``calibrator export-params``: the compensated parameters in robot users' formats."""

import sys
from enum import StrEnum
from pathlib import Path

import typer

from calibrator.cli._app import app


class ExportFormat(StrEnum):
    json = "json"
    csv = "csv"


@app.command("export-params")
def export_params(
    calibration_path: Path = typer.Argument(
        ..., metavar="CALIBRATION", help="Calibration file (JSON) written by identify."
    ),
    fmt: ExportFormat = typer.Option(ExportFormat.json, "--format", help="Output format."),
    output: Path = typer.Option(None, "-o", "--output", help="File to write [default: stdout]."),
):
    """Write the compensated parameters in a format robot users load."""
    from calibrator import calibration, export, outputs

    if output is not None:
        outputs.check(output, inputs=[calibration_path])
    text = export.export(calibration.load(calibration_path), fmt.value)
    if output is None:
        sys.stdout.write(text)
    else:
        outputs.write_text(output, text, inputs=[calibration_path])
        typer.echo(f"wrote {output}")
