"""``calibrator``: the command line. Thin: parses flags, calls the domain, prints.

One module per command (``calibrator/cli/<command>.py``), each registering
itself on :data:`app`. Every domain error becomes one line on stderr and exit
code 2. Heavy modules are imported inside the commands so ``--help`` stays quick.
"""

import sys

import typer

from calibrator.cli._app import app
from calibrator.errors import CalibrationError

# Importing a command module registers its command on ``app``.
from calibrator.cli import simulate as _simulate  # noqa: E402,F401  isort: skip
from calibrator.cli import identify as _identify  # noqa: E402,F401  isort: skip
from calibrator.cli import export as _export  # noqa: E402,F401  isort: skip
from calibrator.cli import measure as _measure  # noqa: E402,F401  isort: skip
from calibrator.cli import plan as _plan  # noqa: E402,F401  isort: skip
from calibrator.cli import compensate as _compensate  # noqa: E402,F401  isort: skip

__all__ = ["app", "main"]


def main(argv=None):
    """Console entry point: run the app, turning known errors into one line."""
    try:
        app(args=argv, prog_name="calibrator")
    except CalibrationError as exc:
        typer.echo(f"calibrator: error: {exc}", err=True)
        sys.exit(2)
    except OSError as exc:
        typer.echo(
            f"calibrator: error: {exc.strerror or exc}: {exc.filename or ''}".rstrip(": "), err=True
        )
        sys.exit(2)
