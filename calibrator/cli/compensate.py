"""``calibrator compensate``: joint angles and corrected targets for the calibrated arm."""

from pathlib import Path

import typer

from calibrator.cli import _checks as checks
from calibrator.cli import _options as opts
from calibrator.cli._app import app


@app.command()
def compensate(
    calibration_path: Path = typer.Argument(
        ..., metavar="CALIBRATION", help="Calibration file (JSON) written by identify."
    ),
    targets_path: Path = typer.Argument(..., metavar="TARGETS", help="CSV of targets."),
    output: Path = opts.output(..., "CSV to write."),
    force: bool = opts.force(),
    payload_kg: float = typer.Option(
        None,
        callback=checks.finite(minimum=0.0),
        help="Working payload (kg) for compliance joint terms [default: the calibration's].",
    ),
) -> None:
    """Joint angles reaching each target on the calibrated arm, and the corrected
    targets to send to a controller that keeps its nominal model.

    TARGETS has columns q1_rad..q6_rad (nominal joint targets of a program), and
    optionally x_mm y_mm z_mm rx_rad ry_rad rz_rad (desired tool pose in the base
    frame, rotation vector); with a pose the joints are the nominal solution to
    start from. Exit code 1 if any target cannot be reached within the joint limits.
    """
    from calibrator import calibration, outputs
    from calibrator import compensate as comp

    outputs.check(output, inputs=[calibration_path, targets_path], force=force)
    cal = calibration.load(calibration_path)
    if payload_kg is not None and not cal.joint_terms.needs_torque:
        typer.echo("note: --payload-kg changes nothing: the calibration has no compliance terms")
    report = comp.run(cal, targets_path, output, payload_kg)
    for line in report.lines:
        typer.echo(line, err=not report.ok)
    if not report.ok:
        raise typer.Exit(1)
