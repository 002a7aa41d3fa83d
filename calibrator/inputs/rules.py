"""What one option may be, declared once: :class:`Rule`.

A rule (type, bounds, budget, unit, meaning, flag) checks the value typed
on a command line and the value recorded in a file (``identify --like``)
alike, so a hand-edited ``generations: 1000000000`` is refused in one line
exactly as ``--generations 1000000000`` is.

Use::

    from calibrator.inputs.rules import Rule

    Rule("particles", int, 2, 1_000, unit="particles").check(-5)   # StrictError
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from calibrator.errors import CalibrationError
from calibrator.inputs.budgets import check_budget
from calibrator.inputs.errors import StrictError
from calibrator.inputs.grammar import MAX_INT, parse_number
from calibrator.inputs.messages import amount, short

__all__ = ["Rule"]


@dataclass(frozen=True)
class Rule:
    """What one option may be, declared once for the command line and for files.

    Attributes
    ----------
    key : str
        Its name where it is recorded (a file's key, a settings attribute).
    kind : {int, float, bool, str, tuple}
        ``tuple``: ``size`` numbers, given as a list or as comma-separated text.
    low, high : float or None
        Bounds of a number (each coordinate of a tuple: ``|v| <= high``);
        ``high`` is the budget (what a typo must not reach).
    open_low, open_high : bool
        The bound itself is excluded.
    unit : str
        Unit named in messages (``"kg"``, ``"particles"``).
    meaning : str
        One phrase saying what it is (help texts, docs).
    flag : str or None
        The command-line option that sets it, if any.
    choices : tuple of str
        The allowed values of a ``str`` (empty: any, or ``parse`` decides).
    parse : callable or None
        ``parse(value) -> value`` for what a range cannot say (a named arm
        or a file); raises :class:`~calibrator.errors.CalibrationError`.
    size : int
        Numbers in a ``tuple``.
    group : str
        Which record it belongs to (e.g. ``"pipeline"``, ``"joint"``).
    """

    key: str
    kind: type
    low: float | None = None
    high: float | None = None
    open_low: bool = False
    open_high: bool = False
    unit: str = ""
    meaning: str = ""
    flag: str | None = None
    choices: tuple[str, ...] = ()
    parse: Callable[[Any], Any] | None = field(default=None, compare=False)
    size: int = 3
    group: str = ""

    def check(self, value: Any, where: str = "") -> Any:
        """``value`` checked and normalised (a float for ``float``, a tuple for ``tuple``).

        ``None`` (not given, not recorded) passes unchanged.

        Raises
        ------
        StrictError
            One line: ``where: must be a whole number >= 2, got -5``.
        """
        if value is None:
            return None
        try:
            return self._check(value)
        except CalibrationError as exc:
            message = str(exc)
            raise StrictError(f"{where}: {message}" if where else message) from None

    def _check(self, value: Any) -> Any:
        if self.kind is bool:
            if not isinstance(value, bool):
                raise StrictError(f"must be true or false, got {short(value)}")
            return value
        if self.kind is str:
            if not isinstance(value, str):
                raise StrictError(f"must be text, got {short(value)}")
            if self.choices and value not in self.choices:
                raise StrictError(
                    f"{short(value)} is not one of {', '.join(map(repr, self.choices))}"
                )
            return self.parse(value) if self.parse is not None else value
        if self.kind is tuple:
            return self._numbers(value)
        return self._number(value)

    def _number(self, value: Any) -> int | float:
        whole = self.kind is int
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise StrictError(f"must be a {'whole ' if whole else ''}number, got {short(value)}")
        if whole and not isinstance(value, int):
            raise StrictError(f"must be a whole number, got {short(value)}")
        if not whole:
            if isinstance(value, int) and abs(value) > MAX_INT:
                raise StrictError(f"the number {amount(value)} is too large")
            value = float(value)
            if not math.isfinite(value):
                raise StrictError(f"must be a finite number, got {value}")
        low_bad = self.low is not None and (
            value <= self.low if self.open_low else value < self.low
        )
        high_bad = self.open_high and self.high is not None and value >= self.high
        if low_bad or high_bad:
            raise StrictError(f"must be {self._span()}, got {amount(value)}")
        if self.high is not None:
            check_budget("", value, self.high, self.unit)
        return value

    @property
    def bounds(self) -> str:
        """The bounds for a help text: ``2..1000``, ``[0, 1)``, ``each within +-2000 mm``."""
        unit = f" {self.unit}" if self.unit and self.unit != self.key else ""
        if self.kind is tuple:
            return f"each within +-{self.high:g}{unit}"
        if self.open_high or self.open_low:
            return (
                self._span()
                .removeprefix("in ")
                .replace("a number ", "")
                .replace("a whole number ", "")
                + unit
            )
        if self.high is None:
            return f">= {self.low:g}{unit}"
        return f"{self.low:g}..{self.high:g}{unit}"

    def _span(self) -> str:
        """The bounds in words: ``a whole number >= 2``, ``in [0, 1)``."""
        if self.open_high and self.high is not None:
            if self.low is None:
                return f"below {self.high:g}"
            return f"in {'(' if self.open_low else '['}{self.low:g}, {self.high:g})"
        kind = "a whole number" if self.kind is int else "a number"
        return f"{kind} {'>' if self.open_low else '>='} {self.low:g}"

    def _numbers(self, value: Any) -> tuple[float, ...]:
        if isinstance(value, str):
            parts = value.split(",")
            if len(parts) != self.size:
                raise StrictError(f"needs {self.size} comma-separated numbers, got {short(value)}")
            numbers = [parse_number(p, "a coordinate") for p in parts]
        elif isinstance(value, list | tuple) and len(value) == self.size:
            numbers = list(value)
        else:
            raise StrictError(f"needs {self.size} numbers, got {short(value)}")
        out = []
        for v in numbers:
            if isinstance(v, bool) or not isinstance(v, int | float):
                raise StrictError(f"needs {self.size} numbers, got {short(v)}")
            if self.high is not None and not abs(v) <= self.high:
                raise StrictError(
                    f"{amount(v)} {self.unit} is beyond +-{self.high:g} {self.unit}".replace(
                        "  ", " "
                    )
                )
            out.append(float(v))
        return tuple(out)
