"""``calibrator report``: plots and one HTML page from calibration.json (and its session)."""

from pathlib import Path

import typer

from calibrator.cli import _model
from calibrator.cli import _options as opts
from calibrator.cli._app import app


@app.command()
def report(
    calibration_path: Path = typer.Argument(
        ..., metavar="CALIBRATION", help="Calibration file (JSON) written by identify."
    ),
    session_path: Path = typer.Argument(
        None,
        metavar="SESSION",
        help="Session it was identified from (Parquet); needed for the per-pose plots.",
    ),
    output: Path = opts.output(Path("report"), "Folder to write the PNGs and index.html into."),
    force: bool = opts.force(),
    verify_paths: list[Path] = typer.Option(
        None, "--verify", help="ISO 9283 result (calibrator verify), repeatable: before, after."
    ),
    model: str = opts.model(
        None,
        "Named model of a calibration that names none [default: the calibration's, else "
        "the session's]; a calibration's arm cannot be changed.",
    ),
) -> None:
    """Write the calibration report: PNG plots and one self-contained HTML page."""
    from calibrator import calibration, outputs, session
    from calibrator.model import consistency
    from calibrator.report import FILES, verify_section, write

    verify_paths = list(verify_paths or [])
    extra = verify_paths + verify_section.data_paths(verify_paths)
    outputs.check_folder(
        output, inputs=[calibration_path, session_path, *extra], files=FILES, force=force
    )
    cal = calibration.load(calibration_path)
    loaded = None if session_path is None else session.load(session_path)
    # The arm the files name (the session's where the calibration names none).
    recorded = [_model.From(cal.model, calibration_path)]
    if loaded is not None:
        recorded.append(_model.From(loaded.meta.model, session_path))
    name = _model.resolve(model, *recorded, default=None)
    cal = _model.calibration(cal, calibration_path, name)
    if loaded is not None:
        consistency.check_session_matches(cal, loaded.meta, str(session_path))
    runs = verify_section.load(verify_paths)
    batch = outputs.Outputs(inputs=[calibration_path, session_path, *extra])
    with batch:
        written = write(
            output, cal, loaded, batch, calibration_path, session_path, runs, force=force
        )
    names = ", ".join(p.name for p in written)
    files = "1 file" if len(written) == 1 else f"{len(written)} files"
    typer.echo(f"wrote {files} into {output}: {names}")
