"""The calibration report: PNG plots and one self-contained HTML page.

``calibrator report calibration.json [session.parquet] -o DIR`` and
``calibrator identify ... --report DIR`` both call :func:`write`. What is
drawn (each plot is also a PNG file in the folder):

============================ =========================================== =========
file                         content                                     needs
============================ =========================================== =========
``pose_errors.png``          per-pose position error, nominal vs          session
                             identified, fitted and held-out poses apart
``error_cdf.png``            cumulative distribution of those errors     session
``error_vs_distance.png``    identified error against distance from the  session
                             tracker (from the robot base for a session
                             in the base frame: there the tracker's
                             position is not recorded)
``convergence.png``          the swarm's best cost per generation        ``solver.convergence``
``deltas.png``               identified parameter deltas, with standard  ``deltas``
                             errors as bars when recorded
``index.html``               all of the above, the accuracy table, the
                             dropped parameters with their reasons
============================ =========================================== =========

What a document or the session does not hold is said on the page ("not
recorded", "give the session file"), never drawn from guesses. Optional
keys of calibration.json that are read when present:
``uncertainty.standard_errors`` (``{name: value}``, same units as
``deltas``; also accepted at the top level), ``solver.convergence``
(``[[generation, best cost], ...]``, or one best cost per generation),
``warnings`` and ``outlier_poses``.

matplotlib is imported only here, with its non-interactive Agg backend.
"""

from pathlib import Path

__all__ = ["FILES", "check_page_free", "write"]

#: Every file the report may write into its folder.
FILES = (
    "pose_errors.png",
    "error_cdf.png",
    "error_vs_distance.png",
    "convergence.png",
    "deltas.png",
    "index.html",
)


def write(folder, doc, session=None, batch=None, calibration_path=None, session_path=None):
    """Render the report into ``folder`` (created if missing).

    Parameters
    ----------
    folder : str or Path
    doc : dict
        A calibration document (:func:`calibrator.calibration.to_json` or
        :func:`calibrator.calibration.load`).
    session : calibrator.session.Session, optional
        The session the calibration was identified from; without it the
        per-pose plots are left out (and the page says so).
    batch : calibrator.outputs.Outputs, optional
        Write as part of this batch; otherwise a batch of its own.
    calibration_path, session_path : str or Path, optional
        Shown on the page; never overwritten (with ``batch``, its own
        ``inputs`` count).

    Returns
    -------
    list of Path
        The files written.
    """
    from calibrator import outputs
    from calibrator.report import data, page, plots

    own = batch is None
    batch = outputs.Outputs(inputs=[calibration_path, session_path]) if own else batch
    # Refuse a file of the report that is an input before drawing anything.
    if Path(folder).is_dir():
        for name in FILES:
            outputs.check(Path(folder) / name, batch.inputs)
        check_page_free(Path(folder))
    content = data.collect(doc, session, calibration_path, session_path)
    images = plots.draw(content)
    html = page.html(content, images)
    try:
        folder = batch.folder(folder)
        written = [batch.bytes(folder / name, png) for name, png in images.items()]
        written.append(batch.text(folder / "index.html", html))
    except BaseException:
        if own:
            batch.discard()
        raise
    if own:
        batch.commit()
    return written


def check_page_free(folder: Path) -> None:
    """Refuse a report folder that already holds an ``index.html``: never replaced.

    Commands that write a report after long work (``identify --report``)
    call this before the work as well.

    Raises
    ------
    calibrator.outputs.OutputError
    """
    from calibrator.outputs import OutputError

    page = folder / "index.html"
    if page.exists() or page.is_symlink():
        raise OutputError(f"{page} already exists; remove it or name another folder with -o")
