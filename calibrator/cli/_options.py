"""Options several commands declare, each declared here once with its checks.

A command names what differs (its default, its help) and takes the flag
names and the check from here, so ``-o`` stays ``-o`` and ``--tool`` keeps
its millimetre budget in every command::

    from calibrator.cli import _options as opts

    output: Path = opts.output(Path("plan.csv"), "Plan CSV to write."),
    model: str = opts.model(help="Named model (joint limits, kinematics, geometry)."),
    tool: str = opts.tool("Reflector position on the flange X,Y,Z, mm."),
    quiet: bool = opts.quiet(),

The options of the commands that move the arm (``--readings``, ``--speed``,
...) are in :mod:`calibrator.cli._run`, built from these.
"""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable
from pathlib import Path
from types import EllipsisType
from typing import Any, NoReturn, get_type_hints

import typer

from calibrator.cli import _checks as checks
from calibrator.inputs import grammar
from calibrator.inputs.errors import StrictError
from calibrator.model import DEFAULT_TOOL_MM


def fail(message: str) -> NoReturn:
    """One line naming what was wrong, exit code 2."""
    typer.echo(f"calibrator: error: {message}", err=True)
    raise typer.Exit(2)


def floats(text: str, n: int, option: str, needs: str) -> list[float]:
    """``text``, ``n`` comma-separated numbers of the strict grammar, or one line naming ``option``.

    ``needs`` says what the option takes (``"X,Y,Z in mm"``). The strict grammar
    refuses what Python's ``float`` would read (``0_5`` as 5, ``nan``, ``inf``);
    exit code 2.
    """
    try:
        values = [grammar.parse_number(v, option) for v in str(text).split(",")]
    except StrictError as exc:
        fail(f"{option} needs {needs}, got {text!r} ({str(exc).removeprefix(option + ': ')})")
    if len(values) != n:
        fail(f"{option} needs {needs}, got {text!r}")
    return values


def positive(default: float | None, help: str, *names: str) -> Any:
    """A finite option above zero (speeds, bands, windows, timeouts)."""
    return typer.Option(default, *names, callback=checks.finite(0.0, inclusive=False), help=help)


def output(default: Path | EllipsisType | None, help: str) -> Any:
    """``-o/--output``: the file (or folder) the command writes; ``...`` makes it required."""
    return typer.Option(default, "-o", "--output", help=help)


def force() -> Any:
    """``--force``: replace existing outputs (without it every command refuses them)."""
    return typer.Option(
        False, "--force", help="Replace existing output files (refused without it)."
    )


def model(default: str | None = "ur10e", help: str = "Named model of the arm.") -> Any:
    """``--model``: a named arm model (``calibrator.robots``)."""
    return typer.Option(default, help=help)


def urdf_links(command: Callable[..., None]) -> Callable[..., None]:
    """Give ``command`` ``--base-link`` and ``--tip-link`` beside its ``--model``.

    They name the chain of a URDF ``--model`` (default: ``base_link`` to
    ``tool0``, else ``flange``), and the command receives them folded into the
    model's name as ``arm.urdf#BASE:TIP``, the name a calibration records and
    every command reads back. Use it below ``@app.command()`` (above
    :func:`~calibrator.cli._run.run_command`, which supplies ``--model``).
    """
    signature = inspect.signature(command)
    if "model" not in signature.parameters:
        raise TypeError(f"{command.__name__} has no --model")
    hints = get_type_hints(command)
    params: list[inspect.Parameter] = []
    for p in signature.parameters.values():
        params.append(p.replace(kind=inspect.Parameter.KEYWORD_ONLY, annotation=hints[p.name]))
        if p.name == "model":
            params += [
                inspect.Parameter(
                    name,
                    inspect.Parameter.KEYWORD_ONLY,
                    default=typer.Option(None, flag, help=f"With a URDF --model: {what}."),
                    annotation=str | None,
                )
                for name, flag, what in (
                    ("base_link", "--base-link", "the chain's first link [default: base_link]"),
                    ("tip_link", "--tip-link", "its last link [default: tool0, else flange]"),
                )
            ]

    @functools.wraps(command)
    def linked(**given: Any) -> None:
        given["model"] = chain_name(given["model"], given.pop("base_link"), given.pop("tip_link"))
        command(**given)

    linked.__signature__ = inspect.Signature(params, return_annotation=None)  # type: ignore[attr-defined]
    linked.__annotations__ = {p.name: p.annotation for p in params}
    return linked


def chain_name(model: str | None, base_link: str | None, tip_link: str | None) -> str | None:
    """``--model`` with ``--base-link`` and ``--tip-link`` folded in: ``arm.urdf#BASE:TIP``."""
    if base_link is None and tip_link is None:
        return model
    path, named, _ = (model or "").partition("#")
    if not path.strip().lower().endswith(".urdf"):
        fail(f"--base-link and --tip-link go with a URDF --model, not {model!r}")
    if named:
        fail(f"--model {model} names its links already: give them once")
    return f"{path}#{base_link or ''}:{tip_link or ''}"


def seed(default: int, help: str) -> Any:
    """``--seed``: a whole number a random generator accepts."""
    return typer.Option(default, callback=checks.seed(), help=help)


def quiet() -> Any:
    """``-q/--quiet``: no progress display."""
    return typer.Option(False, "--quiet", "-q", help="No progress display.")


def yes(help: str) -> Any:
    """``--yes``: do what moves hardware without asking."""
    return typer.Option(False, "--yes", help=help)


#: ``--tool``'s default as the command line writes it: ``0,0,100``.
TOOL_DEFAULT = ",".join(f"{v:g}" for v in DEFAULT_TOOL_MM)


def tool(help: str, default: str | None = TOOL_DEFAULT) -> Any:
    """``--tool X,Y,Z``: a point on the flange, mm, within the tool budget.

    ``default`` None: the command takes it from its plan file (else 0,0,100).
    """
    return typer.Option(default, callback=checks.point_mm("tool"), help=help)


def tracker_at(help: str) -> Any:
    """``--tracker-at X,Y,Z``: the tracker in the robot base frame, mm, within its budget."""
    return typer.Option(None, callback=checks.point_mm("tracker_at"), help=help)


def cell(help: str) -> Any:
    """``--cell``: a cell file (YAML, docs/cell.md)."""
    return typer.Option(None, "--cell", help=help)
