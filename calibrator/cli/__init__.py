"""``calibrator``: the command line. Thin: parses flags, calls the domain, prints.

One module per command (``calibrator/cli/<command>.py``), each registering
itself on :data:`app`. Every bad option and every domain error becomes one
line on stderr and exit code 2 (:func:`main`); option checks live in
:mod:`calibrator.cli._checks`, safe output files in :mod:`calibrator.outputs`.
Heavy modules are imported inside the commands so ``--help`` stays quick.
"""

import atexit
import gc
import importlib
import os
import sys
import warnings
from typing import Any

import typer
from typer._click import exceptions as _click_errors

from calibrator.cli import _app
from calibrator.errors import CalibrationError

#: Command name -> module ``calibrator/cli/<module>.py`` that registers it, in
#: the order of the workflow (the order help lists them in).
COMMANDS = {
    "plan": "plan",
    "program": "program",
    "measure": "measure",
    "tracker": "tracker",
    "identify": "identify",
    "export-params": "export",
    "compensate": "compensate",
    "verify": "verify",
    "check": "check",
    "report": "report",
    "analyze": "analyze",
    "simulate": "simulate",
    "history": "history",
}


#: Commands whose arithmetic is large enough for threaded BLAS (the Monte
#: Carlo of ``analyze``, which also runs its own workers).
MANY_THREADED = frozenset({"analyze"})

__all__ = ["COMMANDS", "app", "main", "register"]

#: Exit code of an interrupted command (128 + SIGINT, as shells report it).
EXIT_INTERRUPTED = 130


def register(names: tuple[str, ...] = tuple(COMMANDS)) -> typer.Typer:
    """Import command modules, which registers their commands on the app.

    A command line names one command, and importing all ten costs a quarter
    of a second at every start (their imports reach the exporters, the
    planner's checks, ...), so :func:`main` registers only the one it runs.

    Parameters
    ----------
    names : iterable of str
        Command names, keys of :data:`COMMANDS` (default: all).

    Returns
    -------
    typer.Typer
        The application, with those commands registered.
    """
    for name in names:
        importlib.import_module(f"calibrator.cli.{COMMANDS[name]}")
    # Keep help in workflow order whatever order the commands were registered in.
    order = {f"calibrator.cli.{module}": i for i, module in enumerate(COMMANDS.values())}
    app = _app.app
    app.registered_commands.sort(key=lambda c: order.get(c.callback.__module__, len(order)))
    app.registered_groups.sort(key=lambda g: list(COMMANDS).index(g.name or ""))
    return app


def _commands_for(argv: list[str]) -> tuple[str, ...]:
    """The commands a command line needs: the one it names, or all of them.

    Help, ``--version``, a missing or unknown command all need the full list,
    so that help lists every command and an error can name the choices.
    """
    if argv and argv[0] in COMMANDS:
        return (argv[0],)
    return tuple(COMMANDS)


def __getattr__(name: str):
    # ``from calibrator.cli import app`` (tests, embedding) gets every command.
    if name == "app":
        return register()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _fail(message, code=2):
    message = " ".join(str(message).replace("\r", "\n").split("\n"))  # one line, always
    typer.echo(f"calibrator: error: {message}", err=True)
    sys.exit(code)


def _dispatch(app: typer.Typer, args: list[str], argv: list[str] | None) -> Any:
    """The command's exit code; a known error printed as one line (``SystemExit``)."""
    from calibrator.cli import _checks

    try:
        _checks.strict_numbers(app, args)
        return app(args=argv, prog_name="calibrator", standalone_mode=False)
    except _click_errors.NoArgsIsHelpError as exc:
        typer.echo(exc.format_message())
        return 0
    except _click_errors.UsageError as exc:
        _fail(_checks.one_line(exc))
    except _click_errors.ClickException as exc:
        _fail(exc.format_message(), exc.exit_code)
    except typer.Abort:  # EOF at a prompt
        _fail("interrupted", EXIT_INTERRUPTED)
    except CalibrationError as exc:
        _fail(exc)
    except OSError as exc:
        _fail(f"{exc.strerror or exc}: {exc.filename or ''}".rstrip(": "))


def main(argv: list[str] | None = None) -> None:
    """Console entry point: run the app, turning known errors into one line.

    Parameters
    ----------
    argv : list of str, optional
        Arguments after the program name (default: ``sys.argv[1:]``).
    """
    args = sys.argv[1:] if argv is None else list(argv)
    if argv is None:
        # The process ends with this command. Python's last garbage collections at
        # exit walk every object the imports made, to free memory the exit frees
        # anyway: 0.2 s after a Dask run, 0.06 s after others (measured). Outputs
        # are written and closed by then. Registered first, so it runs last.
        atexit.register(gc.freeze)
    if not args or args[0] not in MANY_THREADED:
        # Before numpy loads: OpenBLAS reads this once. Our matrices are small
        # (a Jacobian of 6 rows a pose by at most 36 columns), where extra BLAS
        # threads only spin: identify on 30 poses spent 0.15 s more CPU and
        # 0.2 s more wall with them (measured). A user's own setting wins.
        os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    app = register(_commands_for(args))
    # Warnings a library gives on the way to a refusal (numpy's overflow while
    # reading a number the command then refuses) would bury its one line: they
    # are held while the command runs, dropped when it ends refused (exit 2),
    # shown after it otherwise.
    ended: SystemExit | None = None
    with warnings.catch_warnings(record=True) as held:
        try:
            code = _dispatch(app, args, argv)
        except SystemExit as exc:  # a known error, already said in one line
            ended, code = exc, exc.code
    if code != 2:
        for w in held:
            warnings.showwarning(w.message, w.category, w.filename, w.lineno, w.file, w.line)
    if ended is not None:
        raise ended
    # Without standalone mode typer returns the exit code of ``typer.Exit``, and
    # 130 for Ctrl-C inside a command (it catches the KeyboardInterrupt itself).
    if code == EXIT_INTERRUPTED:
        _fail("interrupted", EXIT_INTERRUPTED)
    sys.exit(code if isinstance(code, int) else 0)
