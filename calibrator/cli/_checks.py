"""Checks of command-line option values, shared by every command.

Every check is a typer callback, so a bad value is refused while the command
line is parsed, before any work starts, and :func:`calibrator.cli.main`
prints it as one line with exit code 2::

    calibrator: error: --particles: must be a whole number >= 2, got 0

Use::

    from calibrator.cli import _checks as checks

    particles: int = typer.Option(20, callback=checks.at_least(2), help="Swarm size.")
    generations: int = typer.Option(2000, callback=checks.at_least(0), help="...")
    weight: float = typer.Option(None, callback=checks.finite(minimum=0.0), help="...")
    share: float = typer.Option(0.2, callback=checks.fraction(), help="... in [0, 1).")
    speed: float = typer.Option(0.5, callback=checks.finite(minimum=0.0, inclusive=False))

``None`` (an optional option left out) always passes. Files are checked
elsewhere: inputs by their loaders, outputs by :mod:`calibrator.outputs`.

Budgets: every option that allocates or waits has an upper bound, so a typo
(``--trials 1000000000000``) is refused in one line instead of hanging or
running out of memory. The bounds are in :data:`BUDGETS` (what each costs
is measured in ``benchmarks/``); use them through :func:`count`,
:func:`seconds`, :func:`cores` and :func:`point_mm`::

    trials: int = typer.Option(20000, callback=checks.count("trials"), help="...")
    workers: int = typer.Option(None, callback=checks.cores(), help="...")
    settle: float = typer.Option(0.5, callback=checks.seconds("settle"), help="...")
    tool: str = typer.Option("0,0,100", callback=checks.point_mm("tool"), help="...")
    seed: int = typer.Option(0, callback=checks.seed(), help="...")

A budget over several options (poses times samples) is checked in the
command with :func:`calibrator.inputs.budgets.check_budget`.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

import typer
from typer._click import exceptions as _click_errors

from calibrator.inputs import budgets, grammar
from calibrator.inputs.errors import StrictError
from calibrator.inputs.rules import Rule

__all__ = [
    "BUDGETS",
    "MAX_SEED",
    "at_least",
    "cores",
    "count",
    "file_rows",
    "finite",
    "fraction",
    "one_line",
    "plan_work",
    "point_mm",
    "rule",
    "seconds",
    "seed",
    "strict_numbers",
]

#: Upper bound of each budgeted option: (limit, unit). Sizes are what a
#: calibration cell can use (measuring 2,000 poses takes hours; identify takes
#: at most 50,000); times are what a user would rather be told about than wait.
BUDGETS: dict[str, tuple[float, str]] = {
    # plan: greedy D-optimal selection costs poses x candidates (30 from
    # 100,000 candidates: 20 s, 450 MB).
    "plan_poses": (2_000, "poses"),
    "candidates": (200_000, "candidates"),
    "plan_work": (2e7, "poses x candidates"),
    # identify's options (particles, generations, payload, ...) are bounded by
    # their rules in calibrator.identify.option_rules: --like reads them too.
    # simulate: as many poses as identify takes.
    "simulate_poses": (50_000, "poses"),
    # analyze misalignment: about 100,000 trials/s on one core.
    "trials": (100_000_000, "trials"),
    "sweep_work": (100_000_000, "trials x cases"),
    "sweep_values": (100, "values"),
    # analyze tolerance: about 380 bytes per pose x sample (1,000 x 20,000: 7.6 GB).
    "tolerance_poses": (10_000, "poses"),
    "samples": (100_000, "samples"),
    "tolerance_work": (2_000_000, "poses x samples"),
    # verify: ISO 9283 asks 30 cycles of 5 poses; 1,000 cycles measure for days.
    "cycles": (1_000, "cycles"),
    # analyze deflection: a trajectory of 100,000 samples took 3 s and 380 MB.
    "trajectory_samples": (20_000, "samples"),
    # measure (the lead wires these): readings per pose, seconds of settling.
    "readings": (1_000, "readings"),
    "settle": (60.0, "s"),
    "retries": (100, "retries"),
    # measure --robot external: a band wider than 1 mm takes a slow move for a stop, a
    # window past 10 s outlasts any dwell, a tolerance past 50 mm is another arm, and a
    # program silent for an hour has ended.
    "stop_band": (1.0, "mm"),
    "settle_window": (10.0, "s"),
    "match_tolerance": (50.0, "mm"),
    "stop_timeout": (3600.0, "s"),
    # simulate: noise and offsets a simulated cell can have (beyond them the
    # session is nonsense that identify refuses later).
    "noise_mm": (100.0, "mm"),
    "noise_deg": (10.0, "deg"),
    "noise_rad": (0.1, "rad"),
    # Points in a robot cell, mm: a tool on the flange, a tracker in the room.
    "tool": (2_000.0, "mm"),
    "tracker_at": (100_000.0, "mm"),
    # program: a digital output number (KRL's $OUT[] goes to 4096).
    "pulse": (4096, "outputs"),
}
#: Largest seed: a JSON-safe 64-bit integer (seeds are written into results).
MAX_SEED = grammar.MAX_INT


def count(budget: str, minimum: int = 1) -> Callable[[int | None], int | None]:
    """Callback for a whole number in ``[minimum, BUDGETS[budget]]``.

    Parameters
    ----------
    budget : str
        Key of :data:`BUDGETS`.
    minimum : int
    """
    limit, unit = BUDGETS[budget]

    def check(value: int | None) -> int | None:
        if value is None:
            return value
        if value < minimum:
            raise typer.BadParameter(f"must be a whole number >= {minimum}, got {value}")
        _within(value, limit, unit)
        return value

    return check


def rule(option: Rule) -> Callable[[Any], Any]:
    """Callback checking a value against its declared :class:`calibrator.inputs.rules.Rule`.

    The rule is the one a file's recorded value meets too (``identify
    --like``); the callback returns the checked value (a float for a number,
    a tuple for ``X,Y,Z``).
    """

    def check(value: Any) -> Any:
        try:
            option.check(value)
        except StrictError as exc:
            raise typer.BadParameter(str(exc)) from None
        return value

    return check


def seconds(budget: str, positive: bool = False) -> Callable[[float | None], float | None]:
    """Callback for a time (or any amount in the budget's unit): finite, >= 0, <= the budget.

    ``positive=True`` refuses 0 too (a window or a band of nothing).
    """
    limit, unit = BUDGETS[budget]
    base = finite(minimum=0.0, inclusive=not positive)

    def check(value: float | None) -> float | None:
        value = base(value)
        if value is not None:
            _within(value, limit, unit)
        return value

    return check


def cores() -> Callable[[int | None], int | None]:
    """Callback for a number of worker processes: 1 up to this machine's cores."""

    def check(value: int | None) -> int | None:
        if value is None:
            return value
        if value < 1:
            raise typer.BadParameter(f"must be a whole number >= 1, got {value}")
        limit = os.cpu_count() or 1
        if value > limit:
            raise typer.BadParameter(f"must be at most {limit} (this machine's cores), got {value}")
        return value

    return check


def seed() -> Callable[[int | None], int | None]:
    """Callback for a random seed: a whole number in [0, 2**63 - 1]."""

    def check(value: int | None) -> int | None:
        if value is not None and not 0 <= value <= MAX_SEED:
            raise typer.BadParameter(f"must be a whole number >= 0 and <= 2**63 - 1, got {value}")
        return value

    return check


def point_mm(budget: str) -> Callable[[str | None], str | None]:
    """Callback for ``X,Y,Z`` in mm: three numbers of the strict grammar, each within the budget.

    Returns the text unchanged (the command parses it); refuses ``0,0,1e308``,
    ``nan``, ``0_5`` and anything but three numbers.
    """
    limit, unit = BUDGETS[budget]

    def check(value: str | None) -> str | None:
        if value is None:
            return value
        parts = str(value).split(",")
        if len(parts) != 3:
            raise typer.BadParameter(f"needs X,Y,Z (three numbers, mm), got {value!r}")
        try:
            numbers = [grammar.parse_number(p, "coordinate") for p in parts]
        except StrictError as exc:
            raise typer.BadParameter(str(exc).removeprefix("coordinate: ")) from None
        for v in numbers:
            if abs(v) > limit:
                raise typer.BadParameter(
                    f"{v:g} {unit} is beyond +-{limit:g} {unit} (not a point in a robot cell)"
                )
        return value

    return check


def plan_work(poses: int, candidates: int | None, selection: str) -> None:
    """Refuse a sampled plan whose candidates or selection work exceed their budgets.

    Parameters
    ----------
    poses : int
        ``--poses``.
    candidates : int or None
        ``--candidates``; None for the default ``max(60 poses, 2000)``.
    selection : str
        ``--selection``: only ``d-optimal`` costs poses x candidates.

    Raises
    ------
    calibrator.inputs.errors.StrictError
    """
    n = max(60 * poses, 2000) if candidates is None else candidates
    what = "--candidates" if candidates is not None else f"--candidates (default for {poses} poses)"
    budgets.check_budget(what, n, *BUDGETS["candidates"])
    if selection == "d-optimal":
        budgets.check_budget(
            "--poses x --candidates (lower either)", poses * n, *BUDGETS["plan_work"]
        )


def file_rows(option: str, path: Path, poses: int, selection: str) -> None:
    """Refuse a candidate file with more rows than ``--candidates`` may give.

    A file of candidates costs what sampled ones cost (checks and selection
    per row), so it meets the same budgets (:func:`plan_work`). The rows are
    counted before any is parsed, reading at most the budget's worth of lines.

    Parameters
    ----------
    option : str
        The option naming the file (``"--from"``).
    path : Path
        A missing file is left to its reader (which names it).
    poses, selection : int, str
        As for :func:`plan_work`.

    Raises
    ------
    calibrator.inputs.errors.StrictError
    """
    limit = int(BUDGETS["candidates"][0])
    rows = -1  # the header
    try:
        with open(path, "rb") as fh:
            for rows, _ in enumerate(fh):
                if rows > limit:
                    break
    except OSError:
        return
    if rows > limit:
        raise StrictError(
            f"{option} {path}: more than {limit} rows of candidates (the limit of --candidates)"
        )
    if selection == "d-optimal":
        budgets.check_budget(
            f"{option} {path}: its rows x --poses (lower either)",
            poses * max(rows, 0),
            *BUDGETS["plan_work"],
        )


_WHOLE = re.compile(r"[+-]?[0-9]+")


def strict_numbers(root: typer.Typer, argv: list[str]) -> None:
    """Refuse a number option whose text is outside the project's number grammar.

    typer converts option text with pydantic, which (like ``float()`` and
    ``int()``) reads ``0_5`` as 5 and ``1_000`` as 1000. This walks the
    command line before typer does and checks the text of every ``int`` and
    ``float`` option: whole numbers are ``[+-]digits``, others follow
    :func:`calibrator.inputs.grammar.parse_number` (finite, no underscores, no hex).

    Parameters
    ----------
    root : typer.Typer
        The application.
    argv : list of str
        Arguments after the program name.

    Raises
    ------
    typer.BadParameter
        Bound to the option, so :func:`one_line` names it.
    """
    import typer.main

    command = typer.main.get_command(root)
    i = 0
    while i < len(argv):
        token = argv[i]
        if token == "--":
            return
        sub = getattr(command, "commands", {}).get(token)
        if sub is not None:
            command, i = sub, i + 1
            continue
        name, eq, value = token.partition("=")
        param = _option(command, name) if token.startswith("--") or not eq else None
        if param is None or getattr(param, "is_flag", False) or getattr(param, "count", False):
            i += 1
            continue
        text = value if eq else (argv[i + 1] if i + 1 < len(argv) else None)
        i += 1 if eq else 2
        if text is not None:
            _check_number_text(param, text)


def _option(command, name: str):
    """The option of ``command`` spelled ``name``, or None."""
    for param in getattr(command, "params", ()):
        if name in getattr(param, "opts", ()) or name in getattr(param, "secondary_opts", ()):
            return param if getattr(param, "param_type_name", "") == "option" else None
    return None


def _check_number_text(param, text: str) -> None:
    try:
        kind = param.bare_type()
    except (AttributeError, TypeError):
        return
    if kind == "int" and not _WHOLE.fullmatch(text.strip()):
        raise typer.BadParameter(f"not a whole number, got {text!r}", param=param)
    if kind == "float":
        try:
            grammar.parse_number(text)
        except StrictError:
            raise typer.BadParameter(
                f"must be a finite decimal number, got {text!r}", param=param
            ) from None


def _within(value: float, limit: float, unit: str) -> None:
    try:
        budgets.check_budget("", value, limit, unit)
    except StrictError as exc:
        raise typer.BadParameter(str(exc).removeprefix(": ")) from None


def at_least(minimum: int) -> Callable[[int | None], int | None]:
    """Callback refusing whole numbers below ``minimum``."""

    def check(value: int | None) -> int | None:
        if value is not None and value < minimum:
            raise typer.BadParameter(f"must be a whole number >= {minimum}, got {value}")
        return value

    return check


def finite(
    minimum: float | None = None, maximum: float | None = None, inclusive: bool = True
) -> Callable[[float | None], float | None]:
    """Callback refusing NaN, infinities and values outside ``[minimum, maximum]``.

    ``inclusive=False`` makes both bounds strict.
    """

    def check(value: float | None) -> float | None:
        if value is None:
            return value
        if not math.isfinite(value):
            raise typer.BadParameter(f"must be a finite number, got {value}")
        low = minimum is not None and (value < minimum if inclusive else value <= minimum)
        high = maximum is not None and (value > maximum if inclusive else value >= maximum)
        if low or high:
            raise typer.BadParameter(f"must be {_range(minimum, maximum, inclusive)}, got {value}")
        return value

    return check


def fraction() -> Callable[[float | None], float | None]:
    """Callback for a share of something: a finite number in [0, 1)."""

    def check(value: float | None) -> float | None:
        if value is not None and not (math.isfinite(value) and 0.0 <= value < 1.0):
            raise typer.BadParameter(f"must be a fraction in [0, 1), got {value}")
        return value

    return check


def _range(minimum, maximum, inclusive):
    ge, le = (">=", "<=") if inclusive else (">", "<")
    if maximum is None:
        return f"{ge} {minimum:g}"
    if minimum is None:
        return f"{le} {maximum:g}"
    return f"in [{minimum:g}, {maximum:g}]" if inclusive else f"in ({minimum:g}, {maximum:g})"


# Wording of typer's own (pydantic) coercion errors, made plain.
_PHRASES = (
    ("Value error, ", ""),
    ("Input should be a valid integer, unable to parse string as an integer", "not a whole number"),
    ("Input should be a valid integer", "not a whole number"),
    ("Input should be a valid number, unable to parse string as a number", "not a number"),
    ("Input should be a valid number", "not a number"),
    ("Input should be greater than or equal to", "must be >="),
    ("Input should be less than or equal to", "must be <="),
    ("Input should be greater than", "must be >"),
    ("Input should be less than", "must be <"),
)


def one_line(exc: _click_errors.UsageError) -> str:
    """One line for a click/typer usage error, naming the option at fault.

    Parameters
    ----------
    exc : typer's click ``UsageError``

    Returns
    -------
    str
        E.g. ``--format: 'yaml' is not one of 'json', 'csv'``; errors that
        are not about a value (unknown option, missing argument) end with
        where to find help.
    """
    param = getattr(exc, "param", None)
    bad_value = isinstance(exc, typer.BadParameter) and type(exc).__name__ == "BadParameter"
    if bad_value and param is not None:
        message = exc.message
        for old, new in _PHRASES:
            message = message.replace(old, new)
        message = message.rstrip(".")
        given = _input_of(exc.__cause__)
        if given is not None and str(given) not in message:
            message += f", got {given!r}"
        names = [o for o in param.opts if o.startswith("-")] or [param.name.upper()]
        message = f"{names[0]}: {message}"
    else:
        message = exc.format_message().rstrip(".")
        command = getattr(getattr(exc, "ctx", None), "command_path", None)
        if command:
            message += f" (see '{command} -h')"
    return " ".join(message.split())


def _input_of(cause):
    """The value the user typed, from typer's pydantic validation error if any."""
    try:
        return cause.errors()[0]["input"]
    except (AttributeError, IndexError, KeyError, TypeError):
        return None
