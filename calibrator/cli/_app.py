"""The typer application every command module registers on, and groups spread over modules."""

import typer

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,
    context_settings={"help_option_names": ["-h", "--help"]},
    help="Calibrate 6-axis robot arms with a laser tracker in the loop.",
)

#: ``calibrator analyze``: its commands live in ``analyze.py`` and
#: ``analyze_deflection.py``; ``analyze.py`` adds the group to :data:`app`.
analyze_app = typer.Typer(
    no_args_is_help=True,
    help="Accuracy analysis: how accurate can this arm be, which tolerances matter.",
)


def _print_version(value: bool):
    if value:
        from importlib.metadata import PackageNotFoundError, version

        try:
            typer.echo(f"calibrator {version('calibrator')}")
        except PackageNotFoundError:  # running from a source tree that was never installed
            typer.echo("calibrator (version unknown: not installed)")
        raise typer.Exit()


@app.callback()
def _root(
    version: bool = typer.Option(
        False,
        "--version",
        is_eager=True,
        callback=_print_version,
        help="Print the version and exit.",
    ),
):
    """Calibrate 6-axis robot arms with a laser tracker in the loop."""
