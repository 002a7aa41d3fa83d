"""``calibrator export-params``: the calibrated model in the formats robots and planners read."""

import sys
from enum import StrEnum
from pathlib import Path

import typer

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
) -> None:
    """Write the calibrated model in a format robot users load."""
    from calibrator import calibration, export, outputs

    name = export.choose(None if fmt is None else fmt.value, output)
    if output is not None:
        outputs.check(output, inputs=[calibration_path], force=force)
    result = export.export(calibration.load(calibration_path), name)
    for note in result.notes:
        typer.echo(f"note: {note}", err=True)
    if output is None:
        sys.stdout.write(result.text)
        return
    outputs.write_text(output, result.text, inputs=[calibration_path])
    typer.echo(f"wrote {output} ({name})")
