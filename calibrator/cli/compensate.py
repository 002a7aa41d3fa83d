"""``calibrator compensate``: corrected targets for the calibrated arm (CSV or a robot program)."""

from pathlib import Path

import typer

from calibrator.cli import _checks as checks
from calibrator.cli import _options as opts
from calibrator.cli._app import app
from calibrator.recorded_options import RULES

#: ``--format``'s choices as its help shows them: the languages of
#: :func:`calibrator.languages.registry.readers` (a test keeps the two equal; the
#: languages are not imported to draw the help).
FORMAT_CHOICES = "urscript|krl|rapid|fanuc|jbi"


@app.command()
def compensate(
    calibration_path: Path = typer.Argument(
        ..., metavar="CALIBRATION", help="Calibration file (JSON) written by identify."
    ),
    targets_path: Path = typer.Argument(
        ...,
        metavar="TARGETS",
        help="CSV of targets, or a robot program (.script, .src, .mod/.prg/.modx, .ls, .jbi).",
    ),
    output: Path = opts.output(..., "CSV or program to write (KRL: the .src; its .dat beside it)."),
    force: bool = opts.force(),
    payload_kg: float = typer.Option(
        None,
        callback=checks.rule(RULES["payload_kg"]),
        help="Working payload (kg, 0..100) for compliance joint terms "
        "[default: the calibration's].",
    ),
    fmt: str = typer.Option(
        None,
        "--format",
        metavar=FORMAT_CHOICES,
        help="Program language [default: from the extension].",
    ),
    frames_path: Path = typer.Option(
        None, "--frames", help="YAML of tools, bases and pulse scales the program does not define."
    ),
    config_dat: Path = typer.Option(
        None, "--config-dat", help="KUKA $config.dat holding TOOL_DATA and BASE_DATA."
    ),
    joint_targets: str = typer.Option(
        "keep",
        "--joint-targets",
        metavar="keep|correct",
        help="keep (taught) or correct (offline-programmed) joint targets.",
    ),
    max_correction: str = typer.Option(
        "5,0.5",
        "--max-correction",
        help="Largest correction MM,DEG; a larger one fails its target.",
    ),
    keep_failed: bool = typer.Option(
        False,
        "--keep-failed",
        help="Write the program even if targets failed (left unchanged, marked).",
    ),
    summary_path: Path = typer.Option(None, "--summary", help="Write the filter summary as JSON."),
) -> None:
    """Joint angles reaching each target on the calibrated arm, and the corrected
    targets to send to a controller that keeps its nominal model.

    TARGETS as CSV has columns q1_rad..q6_rad (nominal joint targets of a program), and
    optionally x_mm y_mm z_mm rx_rad ry_rad rz_rad (desired tool pose in the base
    frame, rotation vector); with a pose the joints are the nominal solution to
    start from. A robot program is filtered: every target replaced by the one that
    makes the calibrated arm reach it, everything else byte for byte (docs/compensate.md).
    Exit code 1 if any target fails (no output is written unless --keep-failed).
    """
    from calibrator import calibration, outputs
    from calibrator import compensate as comp

    is_csv = fmt is None and targets_path.suffix.lower() == ".csv"
    outputs.check(output, inputs=[calibration_path, targets_path], force=force)
    if summary_path is not None:
        outputs.check(
            summary_path,
            inputs=[calibration_path, targets_path, output],
            force=force,
            option="--summary",
        )
    if joint_targets not in ("keep", "correct"):
        opts.fail(f"--joint-targets must be keep or correct, got {joint_targets!r}")
    max_mm, max_deg = opts.floats(max_correction, 2, "--max-correction", "MM,DEG")
    if not (0 < max_mm <= 1000 and 0 < max_deg <= 90):
        opts.fail("--max-correction needs 0 < MM <= 1000 and 0 < DEG <= 90")
    if is_csv:
        for name, value in (
            ("--frames", frames_path),
            ("--config-dat", config_dat),
            ("--keep-failed", keep_failed or None),
            ("--joint-targets", None if joint_targets == "keep" else joint_targets),
        ):
            if value is not None:
                opts.fail(f"{name} applies to robot programs, not to a targets CSV")
    cal = calibration.load(calibration_path)
    if payload_kg is not None and not cal.joint_terms.needs_torque:
        typer.echo("note: --payload-kg changes nothing: the calibration has no compliance terms")
    if is_csv:
        report = comp.run(cal, targets_path, output, payload_kg)
        for line in report.lines:
            typer.echo(line, err=not report.ok)
        if not report.ok:
            raise typer.Exit(1)
        return
    _filter(
        cal, targets_path, output, fmt, frames_path, config_dat, joint_targets == "correct",
        max_mm, max_deg, keep_failed, summary_path, payload_kg, force,
    )  # fmt: skip


def _filter(cal, program, output, fmt, frames_path, config_dat, correct, max_mm, max_deg,
            keep_failed, summary_path, payload_kg, force):  # fmt: skip
    from calibrator import robots
    from calibrator.compensate import programs
    from calibrator.languages import frames_file, reading

    language = reading.choose(fmt, program)
    reading.choose(language, output)  # the output must carry the same extension
    if not program.is_file():
        opts.fail(f"{program}: no such file")
    if config_dat is not None and not config_dat.is_file():
        opts.fail(f"{config_dat}: no such file")
    limits = robots.get(cal.model).joint_limits_rad if cal.model else None
    job = reading.Job(
        calibration=cal,
        frames=frames_file.read(frames_path),
        limits=limits,
        correct_joints=correct,
        max_mm=max_mm,
        max_deg=max_deg,
        keep_failed=keep_failed,
        payload_kg=payload_kg,
        config_dat=config_dat,
    )
    summary = programs.run(
        language, job, program, output, [frames_path, config_dat], summary_path, force
    )
    failed = summary.n_failed > 0
    for line in summary.lines():
        typer.echo(line, err=failed)
    if summary.outputs:
        typer.echo(f"wrote {', '.join(summary.outputs)}", err=failed)
    elif failed:
        typer.echo("nothing written: a target failed (--keep-failed writes it anyway)", err=True)
    if failed:
        raise typer.Exit(1)
