"""``calibrator history``: a robot's calibrations, tests and checks over time; import; re-identify.

``calibrator history [ROBOT]`` prints the robots, or one robot's records as
a table (``--csv FILE`` writes it, ``--html DIR`` a page with plots and
alarms); ``history import DIR`` adds existing files; ``history robot`` and
``history tracker`` describe a device; ``history reidentify`` runs identify
again on every stored session (Dask). See docs/history.md.
"""

from __future__ import annotations

from datetime import date
from pathlib import Path
from typing import TYPE_CHECKING, Any

import typer
from typer.core import TyperGroup

from calibrator.cli import _checks as checks
from calibrator.cli import _options as opts
from calibrator.cli._app import app
from calibrator.cli._history_record import record, refuse_unusable
from calibrator.cli._options import fail
from calibrator.errors import CalibrationError

if TYPE_CHECKING:
    from calibrator.history.store import History

# check and verify import these from here; identify from their own module
# (this one imports identify's option reading for reidentify).
__all__ = ["record", "refuse_unusable"]

HISTORY_HELP = (
    "History: an SQLite file or postgresql://USER@HOST/DB; ?timeout=SECONDS bounds every "
    "exchange with it (default 30) and sqlite:///FILE?mode=ro opens a file read-only "
    "[default: $CALIBRATOR_HISTORY, else ~/.local/share/calibrator/history.sqlite]."
)


class _ShowByDefault(TyperGroup):
    """``history [ROBOT] [OPTIONS]`` runs ``history show``: a group cannot take a
    positional argument before its subcommands' names."""

    def parse_args(self, ctx: Any, args: list[str]) -> list[str]:
        if not args or (args[0] not in self.commands and args[0] not in ("--help", "-h")):
            args = ["show", *args]
        return super().parse_args(ctx, args)


history_app = typer.Typer(
    cls=_ShowByDefault,
    help="A per-robot history of calibrations, ISO 9283 tests and checks (docs/history.md). "
    "'calibrator history [ROBOT] [OPTIONS]' is 'history show': its options (--history, "
    "--csv FILE, --html DIR, the alarm limits) are listed by 'calibrator history show -h'.",
)
app.add_typer(history_app, name="history")


def _history_option() -> Any:
    return typer.Option(None, "--history", metavar="FILE|URL", help=HISTORY_HELP)


def _limit_option(flag: str, what: str) -> Any:
    """An alarm threshold option of ``show`` and ``alarms`` (mm, > 0)."""
    return typer.Option(
        None,
        flag,
        callback=checks.finite(minimum=0.0, inclusive=False),
        help=f"Alarm above this {what} (mm) [default: twice the first].",
    )


@history_app.command("show")
def show(
    robot: str = typer.Argument(None, help="The robot [default: list the robots]."),
    history: str = _history_option(),
    csv_path: Path = typer.Option(None, "--csv", metavar="FILE", help="Write the table as CSV."),
    html_dir: Path = typer.Option(
        None, "--html", metavar="DIR", help="Write the history page (index.html) into DIR."
    ),
    force: bool = opts.force(),
    held_out_limit: float = _limit_option("--held-out-limit-mm", "held-out error"),
    ap_limit: float = _limit_option("--ap-limit-mm", "ISO 9283 AP"),
    rp_limit: float = _limit_option("--rp-limit-mm", "ISO 9283 RP"),
) -> None:
    """The robots, or one robot's records over time and its alarms."""
    from calibrator import outputs
    from calibrator.history import alarms, open_history, timeline

    inputs = []
    if history and "://" not in history:
        inputs.append(Path(history))
    if csv_path is not None:
        outputs.check(csv_path, inputs=inputs, force=force, option="--csv")
    if html_dir is not None:
        outputs.check_folder(
            html_dir, inputs=inputs, files=("index.html",), force=force, option="--html"
        )
    with open_history(history, create=False) as store:
        if robot is None:
            if csv_path is not None or html_dir is not None:
                fail("--csv and --html need a ROBOT")
            _print_robots(store)
            return
        data = timeline.load(store, robot)
    limits = alarms.Limits(held_out_mm=held_out_limit, ap_mm=ap_limit, rp_mm=rp_limit)
    found = alarms.alarms(
        data.calibrations, data.verifications, data.checks, limits, data.circle_checks
    )
    notes = alarms.not_compared(data.calibrations)
    rows = timeline.table(data)
    typer.echo(timeline.format_table(rows))
    for alarm in found:
        typer.echo(f"ALARM {alarm.time:%Y-%m-%d %H:%M:%S} {alarm.kind}: {safe(alarm.message)}")
    if not found:
        typer.echo("no alarms")
    for note in notes:
        typer.echo(f"note: {safe(note)}")
    with outputs.Outputs(inputs=inputs) as batch:
        if csv_path is not None:
            batch.text(csv_path, timeline.csv_text(rows))
        if html_dir is not None:
            from calibrator.history import page

            batch.text(batch.folder(html_dir) / "index.html", page.html(data, found, limits, notes))
    for what, path in (("table", csv_path), ("page", html_dir)):
        if path is not None:
            typer.echo(f"wrote the {what} to {path}")


@history_app.command("alarms")
def alarms_(
    robot: str = typer.Argument(None, help="The robot [default: every robot]."),
    history: str = _history_option(),
    csv_path: Path = typer.Option(
        None, "--csv", metavar="FILE", help="Write the alarms as CSV ('-': to stdout)."
    ),
    json_path: Path = typer.Option(
        None, "--json", metavar="FILE", help="Write the alarms as JSON ('-': to stdout)."
    ),
    force: bool = opts.force(),
    held_out_limit: float = _limit_option("--held-out-limit-mm", "held-out error"),
    ap_limit: float = _limit_option("--ap-limit-mm", "ISO 9283 AP"),
    rp_limit: float = _limit_option("--rp-limit-mm", "ISO 9283 RP"),
) -> None:
    """The alarms of one robot (or every robot) as data: exact times, records compared,
    figure and threshold (docs/history.md)."""
    import json

    from calibrator import outputs
    from calibrator.history import alarms, open_history, timeline

    inputs = [Path(history)] if history and "://" not in history else []
    for path, option in ((csv_path, "--csv"), (json_path, "--json")):
        if path is not None and str(path) != "-":
            outputs.check(path, inputs=inputs, force=force, option=option)
    limits = alarms.Limits(held_out_mm=held_out_limit, ap_mm=ap_limit, rp_mm=rp_limit)
    rows: list[dict] = []
    notes: list[str] = []
    with open_history(history, create=False) as store:
        names = [robot] if robot is not None else [r["name"] for r in store.robots()]
        for name in names:
            data = timeline.load(store, name)
            found = alarms.alarms(
                data.calibrations, data.verifications, data.checks, limits, data.circle_checks
            )
            rows += alarms.as_rows(found, name)
            notes += [f"{name}: {n}" for n in alarms.not_compared(data.calibrations)]
    texts = {
        csv_path: alarms.csv_text(rows),
        json_path: json.dumps({"alarms": rows, "not_compared": notes}, indent=2) + "\n",
    }
    to_stdout = [t for p, t in texts.items() if p is not None and str(p) == "-"]
    if len(to_stdout) > 1:
        fail("--csv - and --json -: only one of them can go to stdout")
    with outputs.Outputs(inputs=inputs) as batch:
        for path, text in texts.items():
            if path is not None and str(path) != "-":
                batch.text(path, text)
    if to_stdout:
        typer.echo(to_stdout[0], nl=False)
        return
    for r in rows:
        typer.echo(
            f"ALARM {safe(r['robot'])} {r['time']} {r['kind']} [{r['records']}]: "
            f"{safe(r['message'])}"
        )
    if not rows:
        typer.echo("no alarms")
    for note in notes:
        typer.echo(f"note: {safe(note)}")
    for path in (csv_path, json_path):
        if path is not None:
            typer.echo(f"wrote the alarms to {path}")


def safe(text: object) -> str:
    """``text`` for one line of a terminal: control characters (escapes, newlines) spelled out.

    Names come from files and other people's commands: a robot named with a
    newline or a terminal escape must not forge a line of a table or recolour
    the terminal. ``\n`` is shown as the two characters ``\n``, an escape as ``\x1b``.
    """
    value = "" if text is None else str(text)
    if value.isprintable():
        return value
    return "".join(
        c if c.isprintable() else c.encode("unicode_escape").decode("ascii") for c in value
    )


def _print_robots(store: History) -> None:
    robots = store.robots()
    if not robots:
        typer.echo(f"no robots in the history {store.where} yet")
        return
    typer.echo(f"{'robot':40s} {'model':12s} {'serial':12s} calibrations")
    for r in robots:
        typer.echo(
            f"{safe(r['name']):40s} {safe(r['model']):12s} {safe(r['serial']):12s} "
            f"{r['calibrations']}"
        )


@history_app.command("import")
def import_(
    folder: Path = typer.Argument(..., metavar="DIR", help="Folder with sessions and JSON files."),
    history: str = _history_option(),
    robot: str = typer.Option(None, help="The robot of files that name none."),
) -> None:
    """Add the sessions (.parquet), calibrations, verify, check and circle files (.json) under DIR.

    Sessions first, so calibrations find their robot; a file already in the
    history is not added again; files that are none of these are skipped.
    """
    from calibrator.history import importing, open_history

    if not folder.is_dir():
        fail(f"not a folder: {folder}")
    with open_history(history) as store:
        counts = importing.import_folder(store, folder, robot, on_skip=_skipped)
        typer.echo(
            f"{counts['session']} sessions, {counts['calibration']} calibrations, "
            f"{counts['verification']} verifications, {counts['check']} checks, "
            f"{counts['circle']} circle checks in the history {store.where}"
        )


def _skipped(path: Path, why: str) -> None:
    typer.echo(f"skipped {safe(path)}: {safe(why)}", err=True)


@history_app.command("robot")
def robot_(
    name: str = typer.Argument(..., help="The robot's name (as the history shows it)."),
    history: str = _history_option(),
    model: str = typer.Option(None, help="Model."),
    serial: str = typer.Option(None, help="Serial number."),
    description: str = typer.Option(None, help="Where it is, what it does."),
) -> None:
    """Add a robot or set its model, serial number and description."""
    from calibrator.history import open_history

    with open_history(history) as store:
        store.describe_robot(name, model, serial, description)
        typer.echo(f"robot {safe(name)} described in the history {store.where}")


@history_app.command("tracker")
def tracker_(
    name: str = typer.Argument(
        ..., help="The tracker as it identifies itself (vendor:model:serial)."
    ),
    history: str = _history_option(),
    model: str = typer.Option(None, help="Model."),
    serial: str = typer.Option(None, help="Serial number."),
    certificate: str = typer.Option(
        None, metavar="YYYY-MM-DD", help="Date of its calibration certificate."
    ),
) -> None:
    """Add a tracker or set its model, serial number and certificate date."""
    from calibrator.history import open_history

    when = None
    if certificate is not None:
        try:
            when = date.fromisoformat(certificate)
        except ValueError:
            fail(f"--certificate {certificate!r}: give a date YYYY-MM-DD")
    with open_history(history) as store:
        store.describe_tracker(name, model, serial, when)
        typer.echo(f"tracker {safe(name)} described in the history {store.where}")


@history_app.command("reidentify")
def reidentify(
    robot: str = typer.Option(None, help="Only this robot's sessions [default: every robot's]."),
    history: str = _history_option(),
    folder: Path = typer.Option(
        Path("reidentified"),
        "-o",
        "--output",
        metavar="DIR",
        help="Folder for the new calibration files (SESSION-DIGEST.json).",
    ),
    identify_options: str = typer.Option(
        "",
        "--identify-options",
        metavar="OPTIONS",
        help='identify\'s options for every session, e.g. "--method lm --seed 2" '
        "[default: identify's defaults].",
    ),
    workers: int = typer.Option(
        None, callback=checks.at_least(1), help="Run on a local Dask cluster of N workers."
    ),
    scheduler: str = typer.Option(
        None, metavar="ADDRESS", help="Run on this Dask scheduler (tcp://HOST:8786)."
    ),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress display."),
) -> None:
    """Identify every stored session again and record the results as new calibrations.

    Each result is what identify gives on that session with these options
    (bit for bit); the sessions must be where the history recorded them.
    """
    import time

    from calibrator import outputs
    from calibrator.cli import progress
    from calibrator.history import open_history
    from calibrator.history import reidentify as redo

    if workers is not None and scheduler is not None:
        fail("give --workers or --scheduler, not both")
    options = _identify_request(identify_options)
    with open_history(history, create=False) as store:
        jobs = redo.plan(store, robot, folder, on_skip=_skipped)
        if not jobs:
            typer.echo("no stored session to identify again")
            return
        outputs.check_folder(folder)
        folder.mkdir(parents=True, exist_ok=True)
        started = time.perf_counter()
        reporter = progress.Reporter.for_cli(quiet)
        failed = 0
        with reporter.task("reidentify", len(jobs), "sessions") as task:
            for done, (job, code, error) in enumerate(
                redo.run(jobs, identify_one, options, workers, scheduler), start=1
            ):
                if code == 0:
                    store.record_calibration(job.output, robot=job.robot)
                else:
                    failed += 1
                    last = error.strip().splitlines()[-1] if error.strip() else f"exit {code}"
                    typer.echo(f"{job.session}: {last}", err=True)
                task.update(done)
        took = time.perf_counter() - started
        typer.echo(
            f"identified {len(jobs) - failed} of {len(jobs)} sessions again in {took:.1f} s; "
            f"recorded in the history {store.where}, files in {folder}"
        )
    if failed:
        raise typer.Exit(1)


def _identify_request(text: str) -> Any:
    """``--identify-options`` read as identify reads its options (one line if refused)."""
    from calibrator.cli.identify import asked_by
    from calibrator.history import reidentify as redo
    from calibrator.history.records import HistoryError

    args = redo.parse_options(text)
    try:
        return asked_by(args)
    except CalibrationError as exc:
        raise HistoryError(f"--identify-options {text!r}: {exc}") from None


def identify_one(session: str, output: str, asked: Any) -> tuple[int, str]:
    """Identify ``session`` into ``output`` as ``calibrator identify`` does, in this process.

    What ``history reidentify`` runs on each session (in a Dask worker, which
    finds this function by its name): identify's own function
    (:func:`calibrator.identify.calibrate.run`), so a result is what
    ``identify`` writes.

    Parameters
    ----------
    session, output : str
    asked : calibrator.cli.identify.Asked
        The options, model, nominal file and joint terms (:func:`_identify_request`).

    Returns
    -------
    code : int
        0: written; 2: refused, as identify would exit.
    error : str
        The refusal, as identify prints it (``calibrator: error: ...``).
    """
    from calibrator.identify.calibrate import run

    try:
        run(
            [session], output, asked.options, model=asked.model,
            nominal_file=asked.nominal_file, joint=asked.joint,
        )  # fmt: skip
    except CalibrationError as exc:
        return 2, f"calibrator: error: {' '.join(str(exc).splitlines())}\n"
    except OSError as exc:
        return 2, f"calibrator: error: {exc.strerror or exc}: {exc.filename or ''}".rstrip(": ")
    return 0, ""
