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
                             errors as bars when recorded; joint lengths
                             (mm), joint angles (mrad), frame offsets
                             (mm) and frame turns (mrad) in panels of
                             their own, so metre-scale base offsets do
                             not flatten joint deltas
``index.html``               all of the above, the summary (loss, residual
                             sigma, predicted held-out error, correlated
                             pairs, outliers, date, robot, tracker,
                             readings per pose), the accuracy table, the
                             parameters (nominal, identified, delta and
                             standard error in mm and mrad), the dropped
                             parameters with their reasons
============================ =========================================== =========

What a calibration or the session does not hold is said on the page ("not
recorded", "give the session file"), never drawn from guesses. The page
reads a :class:`calibrator.calibration.Calibration`: its provenance (loss,
method, seed, ...), its fit report (statistics, standard errors, residual
sigma, predicted held-out error, correlated pairs, warnings, outliers,
convergence) and, from the session, the date, the robot and tracker and
the readings per pose.

matplotlib is imported only here, with its non-interactive Agg backend.
"""

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from calibrator.calibration import Calibration
    from calibrator.outputs import Outputs
    from calibrator.session import Session

__all__ = ["FILES", "check_page_free", "write"]

#: Every file the report may write into its folder.
FILES = (
    "pose_errors.png",
    "error_cdf.png",
    "error_vs_distance.png",
    "convergence.png",
    "deltas.png",
    "verify_clouds.png",
    "verify_path.png",
    "index.html",
)


def write(
    folder: str | Path,
    cal: "Calibration",
    session: "Session | None" = None,
    batch: "Outputs | None" = None,
    calibration_path: str | Path | None = None,
    session_path: str | Path | None = None,
    verify: Sequence = (),
    force: bool = False,
    option: str = "-o",
) -> list[Path]:
    """Render the report into ``folder`` (created if missing).

    Parameters
    ----------
    folder : str or Path
    cal : calibrator.calibration.Calibration
    session : calibrator.session.Session, optional
        The session the calibration was identified from; without it the
        per-pose plots are left out (and the page says so).
    batch : calibrator.outputs.Outputs, optional
        Write as part of this batch; otherwise a batch of its own.
    calibration_path, session_path : str or Path, optional
        Shown on the page; never overwritten (with ``batch``, its own
        ``inputs`` count).
    verify : list of calibrator.report.verify_section.VerifyRun
        ISO 9283 runs (``calibrator verify``): a section of their own.
    force : bool
        Replace the report's files if ``folder`` already holds them
        (refused otherwise, naming ``option``: see :mod:`calibrator.outputs`).
    option : str
        The command's option that named ``folder``.

    Returns
    -------
    list of Path
        The files written.
    """
    from calibrator import outputs
    from calibrator.report import data, page, plots

    own = batch is None
    if batch is None:
        batch = outputs.Outputs(inputs=[calibration_path, session_path])
    # Refuse a file of the report that is an input, or exists, before drawing anything.
    outputs.check_folder(folder, batch.inputs, files=FILES, force=force, option=option)
    content = data.collect(cal, session, calibration_path, session_path)
    images = plots.draw(content)
    html = page.html(content, images)
    if verify:
        from calibrator.report import verify_section

        html, extra = verify_section.add(html, list(verify))
        images.update(extra)
    try:
        into = Path(batch.folder(folder))
        written = [batch.bytes(into / name, png) for name, png in images.items()]
        written.append(batch.text(into / "index.html", html))
    except BaseException:
        if own:
            batch.discard()
        raise
    if own:
        batch.commit()
    return written


def check_page_free(folder: Path, force: bool = False, option: str = "-o") -> None:
    """Refuse a folder that already holds an ``index.html`` unless ``force`` (the output policy).

    Raises
    ------
    calibrator.outputs.OutputError
    """
    from calibrator import outputs

    outputs.check_folder(folder, files=("index.html",), force=force, option=option)
