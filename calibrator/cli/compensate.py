"""``calibrator compensate``: joint angles and corrected targets for the calibrated arm."""

from pathlib import Path

import typer

from calibrator.cli._app import app
from calibrator.errors import CalibrationError


@app.command()
def compensate(
    calibration_path: Path = typer.Argument(..., metavar="CALIBRATION"),
    targets_path: Path = typer.Argument(..., metavar="TARGETS", help="CSV of targets."),
    output: Path = typer.Option(..., "-o", "--output", help="CSV to write."),
):
    """Joint angles reaching each target on the calibrated arm, and the corrected
    targets to send to a controller that keeps its nominal model.

    TARGETS has columns q1_rad..q6_rad (nominal joint targets of a program), and
    optionally x_mm y_mm z_mm rx_rad ry_rad rz_rad (desired tool pose in the base
    frame, rotation vector); with a pose the joints are the nominal solution to
    start from. Exit code 1 if any target cannot be reached within the joint limits.
    """
    from calibrator import calibration
    from calibrator import compensate as comp

    if output.resolve() in (calibration_path.resolve(), targets_path.resolve()):
        raise CalibrationError(f"refusing to overwrite an input with {output}")
    cal = calibration.load(calibration_path)
    report = comp.run(cal, targets_path, output)
    for line in report.lines:
        typer.echo(line, err=not report.ok)
    if not report.ok:
        raise typer.Exit(1)
