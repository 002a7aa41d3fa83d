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
"""

import math

import typer

__all__ = ["at_least", "finite", "fraction", "one_line"]


def at_least(minimum):
    """Callback refusing whole numbers below ``minimum``."""

    def check(value: int | None):
        if value is not None and value < minimum:
            raise typer.BadParameter(f"must be a whole number >= {minimum}, got {value}")
        return value

    return check


def finite(minimum=None, maximum=None, inclusive=True):
    """Callback refusing NaN, infinities and values outside ``[minimum, maximum]``.

    ``inclusive=False`` makes both bounds strict.
    """

    def check(value: float | None):
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


def fraction():
    """Callback for a share of something: a finite number in [0, 1)."""

    def check(value: float | None):
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


def one_line(exc):
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
