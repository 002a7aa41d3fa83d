"""``calibrator``: the command line. Thin: parses flags, calls the domain, prints.

One module per command (``calibrator/cli/<command>.py``), each registering
itself on :data:`app`. Every bad option and every domain error becomes one
line on stderr and exit code 2 (:func:`main`); option checks live in
:mod:`calibrator.cli._checks`, safe output files in :mod:`calibrator.outputs`.
Heavy modules are imported inside the commands so ``--help`` stays quick.
"""

import sys

import typer
from typer._click import exceptions as _click_errors

from calibrator.cli._app import app
from calibrator.errors import CalibrationError

# Importing a command module registers its command on ``app``; help lists them
# in this order, the order of the workflow.
from calibrator.cli import plan as _plan  # noqa: E402,F401  isort: skip
from calibrator.cli import program as _program  # noqa: E402,F401  isort: skip
from calibrator.cli import measure as _measure  # noqa: E402,F401  isort: skip
from calibrator.cli import tracker as _tracker  # noqa: E402,F401  isort: skip
from calibrator.cli import identify as _identify  # noqa: E402,F401  isort: skip
from calibrator.cli import export as _export  # noqa: E402,F401  isort: skip
from calibrator.cli import compensate as _compensate  # noqa: E402,F401  isort: skip
from calibrator.cli import verify as _verify  # noqa: E402,F401  isort: skip
from calibrator.cli import report as _report  # noqa: E402,F401  isort: skip
from calibrator.cli import analyze as _analyze  # noqa: E402,F401  isort: skip
from calibrator.cli import simulate as _simulate  # noqa: E402,F401  isort: skip

__all__ = ["app", "main"]

#: Exit code of an interrupted command (128 + SIGINT, as shells report it).
EXIT_INTERRUPTED = 130


def _fail(message, code=2):
    message = " ".join(str(message).replace("\r", "\n").split("\n"))  # one line, always
    typer.echo(f"calibrator: error: {message}", err=True)
    sys.exit(code)


def main(argv=None):
    """Console entry point: run the app, turning known errors into one line.

    Parameters
    ----------
    argv : list of str, optional
        Arguments after the program name (default: ``sys.argv[1:]``).
    """
    from calibrator.cli import _checks

    try:
        code = app(args=argv, prog_name="calibrator", standalone_mode=False)
    except _click_errors.NoArgsIsHelpError as exc:
        typer.echo(exc.format_message())
        code = 0
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
    # Without standalone mode typer returns the exit code of ``typer.Exit``, and
    # 130 for Ctrl-C inside a command (it catches the KeyboardInterrupt itself).
    if code == EXIT_INTERRUPTED:
        _fail("interrupted", EXIT_INTERRUPTED)
    sys.exit(code if isinstance(code, int) else 0)
