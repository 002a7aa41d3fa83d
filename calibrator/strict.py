"""Strict reading of what users hand in: one number grammar, one JSON and one YAML loader, budgets.

Every file reader of the project reads its numbers, JSON and YAML through
here, so a quirk of one parser cannot turn into silently wrong data:

- :func:`parse_number` accepts decimal numbers only
  (``[+-]digits[.digits][e[+-]digits]``). Python's ``float()`` also takes
  ``0_5`` (as 5.0), ``nan``, ``inf`` and ``infinity``; pandas and YAML 1.1
  take hex, octal and ``1:30``. None of those is a joint angle or a length.
- :func:`load_json` refuses duplicate keys (Python keeps the last one
  silently), ``NaN``/``Infinity``, numbers that overflow to infinity
  (``1e400``) and integers beyond 64 bits (``math.isfinite`` raises
  ``OverflowError`` on an integer above about 1e308).
- :func:`load_yaml` does the same for YAML: duplicate keys, ``.nan``/``.inf``,
  hex/octal/sexagesimal/underscored numbers are refused, and a plain
  ``1e-3`` reads as the number YAML 1.2 says it is (YAML 1.1 reads it as text).
  It is :func:`calibrator.yamlfile.loads`, the one YAML reader, which also
  limits size, depth and alias expansion.
- :func:`check_budget` is the one size/time budget check: an option that
  allocates or waits is refused above its limit before any work starts.
- :class:`Rule` declares once what an option may be (type, bounds, budget,
  meaning); the same rule checks the value typed on a command line and the
  value recorded in a file (``identify --like``).

Every refusal is a :class:`StrictError` (a
:class:`~calibrator.errors.CalibrationError`): one line, exit code 2 at the CLI.

Use::

    from calibrator import strict

    strict.parse_number("0.25")            # 0.25; "0_5", "0x1", "nan" raise
    doc = strict.load_json(text, "calibration.json")
    doc = strict.load_yaml(text, "kinematics.yaml")
    strict.check_budget("--trials", 10**12, 10**9, "trials")
    strict.Rule("particles", int, 2, 1_000, unit="particles").check(-5)  # raises
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from calibrator.errors import CalibrationError

__all__ = [
    "MAX_INT",
    "Rule",
    "StrictError",
    "check_budget",
    "load_json",
    "load_yaml",
    "parse_columns",
    "parse_number",
    "parse_numbers",
    "read_text",
    "shown",
]

#: Largest integer magnitude a file may hold: int64 (seeds, counts, pose numbers).
MAX_INT = 2**63 - 1
#: The number grammar: optional sign, digits with an optional fraction (or a
#: fraction alone), optional exponent. ASCII digits only (\\d would take any
#: script's digits, as float() does). No underscores, no hex, no words.
NUMBER = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
_INTEGER = re.compile(r"[+-]?[0-9]+")
#: Longest text read as one number (a double needs 17 significant digits).
_MAX_NUMBER_CHARS = 64


class StrictError(CalibrationError, ValueError):
    """An input that does not follow the strict grammar or exceeds its budget."""


def parse_number(text: str, what: str = "value") -> float:
    """A finite float from text in the strict decimal grammar.

    Parameters
    ----------
    text : str
        Surrounding whitespace is ignored.
    what : str
        Named in the error (e.g. ``"plan.csv row 3, q2_rad"``).

    Returns
    -------
    float

    Raises
    ------
    StrictError
        Not a decimal number (``0_5``, ``0x10``, ``nan``, ``inf``, empty) or
        too large for a double (``1e400``).
    """
    s = str(text).strip()
    if len(s) > _MAX_NUMBER_CHARS or not NUMBER.fullmatch(s):
        raise StrictError(f"{what}: {_shown(s)} is not a decimal number")
    value = float(s)
    if not math.isfinite(value):
        raise StrictError(f"{what}: {_shown(s)} is too large for a number")
    return value


def parse_numbers(cells: object, what: str = "value") -> np.ndarray:
    """:func:`parse_number` over an array of texts, any shape, as float64."""
    arr = np.asarray(cells, dtype=object)
    out = np.empty(arr.shape, dtype=float)
    for index, cell in np.ndenumerate(arr):
        out[index] = parse_number("" if cell is None else cell, what)
    return out


def parse_columns(rows: Any, names: Any, what: str, first: int = 0) -> np.ndarray:
    """The cells of a CSV's columns as floats, shape (N, len(names)).

    Parameters
    ----------
    rows : sequence of sequences of str, shape (N, len(names))
        The cells of the data rows, in file order (the header is line 1).
    names : sequence of str
        Column names, for the error.
    what : str
        The file, for the error.
    first : int
        Data rows of the file before ``rows`` (a file read in blocks).

    Raises
    ------
    StrictError
        Naming the file, the line and the column: ``p.csv: line 3, q1_rad:
        '0_5' is not a decimal number``.
    """
    names = tuple(names)
    out = np.empty((len(rows), len(names)), dtype=float)
    for i, row in enumerate(rows):
        for j, cell in enumerate(row):
            out[i, j] = parse_number(
                "" if cell is None else cell, f"{what}: line {first + i + 2}, {names[j]}"
            )
    return out


def read_text(path: str | Path, max_bytes: int, what: str = "a text file") -> str:
    """The UTF-8 text of a file no larger than ``max_bytes``.

    ``what`` names the kind of file in the errors (``"a UR calibration file"``).

    Raises
    ------
    StrictError
        Missing, too large, not a file or not UTF-8.
    """
    path = Path(path)
    if not path.is_file():
        raise StrictError(f"{path}: no such file")
    size = path.stat().st_size
    if size > max_bytes:
        raise StrictError(f"{path}: {size} bytes is too large for {what} (at most {max_bytes})")
    try:
        return path.read_bytes().decode("utf-8")
    except UnicodeDecodeError:
        raise StrictError(f"{path}: not {what} (not UTF-8 text)") from None


def load_json(text: str | bytes, where: str = "JSON") -> Any:
    """Parse strict JSON.

    Parameters
    ----------
    text : str or bytes
    where : str
        Named in the error (a path, or ``"the 'calibrator' metadata"``).

    Returns
    -------
    The parsed value (dicts, lists, str, int, float, bool, None).

    Raises
    ------
    StrictError
        Not JSON, a duplicate key, ``NaN``/``Infinity``, a number that
        overflows a double, an integer beyond 64 bits, nesting too deep.
    """
    if isinstance(text, bytes):
        try:
            text = text.decode("utf-8")
        except UnicodeDecodeError:
            raise StrictError(f"{where} is not JSON") from None
    try:
        doc = json.loads(
            text,
            object_pairs_hook=_unique_keys,
            parse_constant=lambda name: _Bad(f"{name} is not allowed (strict JSON)"),
            parse_float=_finite_float,
            parse_int=_bounded_int,
        )
    except StrictError as exc:
        raise StrictError(f"{where}: {exc}") from None
    except RecursionError:
        raise StrictError(f"{where} is not JSON") from None
    except ValueError:  # JSONDecodeError, and int() beyond its digit limit
        raise StrictError(f"{where} is not JSON") from None
    found = _first_bad(doc)
    if found is not None:
        key, bad = found
        raise StrictError(f"{where}: {key + ': ' if key else ''}{bad.reason}")
    return doc


class _Bad:
    """A refused number, kept in place while parsing so the error can name its key."""

    def __init__(self, reason: str):
        self.reason = reason


#: Keys shown bare in a path (``a.b``); any other is shown quoted (``a['x\\n']``).
_PLAIN_KEY = re.compile(r"[A-Za-z0-9_-]+")


def first_leaf(
    value: object, test: Callable[[object], bool], where: str = ""
) -> tuple[str, object] | None:
    """The first leaf of a parsed document that ``test`` picks, with its key path.

    Parameters
    ----------
    value : dicts, lists and leaves, as parsed from JSON or YAML
    test : callable
        True for the leaf wanted.
    where : str
        Path of ``value`` itself (``""`` for a whole document).

    Returns
    -------
    (str, leaf) or None
        Its path (``a.b[2]``) and the leaf, or None when no leaf matches.
    """
    if test(value):
        return where, value
    if isinstance(value, dict):
        items: Iterable[tuple[object, object]] = value.items()
    elif isinstance(value, list):
        items = enumerate(value)
    else:
        return None
    for key, item in items:
        if isinstance(key, int):
            path = f"{where}[{key}]"
        elif isinstance(key, str) and _PLAIN_KEY.fullmatch(key):
            path = f"{where}.{key}" if where else key
        else:  # a key a message cannot show as is (a newline, a dot, nothing): quoted
            path = f"{where}[{key!r}]"
        found = first_leaf(item, test, path)
        if found is not None:
            return found
    return None


def _first_bad(value: object) -> tuple[str, _Bad] | None:
    """Key path and marker of the first refused number in a parsed document."""
    found = first_leaf(value, lambda leaf: isinstance(leaf, _Bad))
    if found is None or not isinstance(found[1], _Bad):
        return None
    return found[0], found[1]


def _unique_keys(pairs: list[tuple[str, object]]) -> dict[str, object]:
    out: dict[str, object] = {}
    for key, value in pairs:
        if key in out:
            raise StrictError(f"key {key!r} appears more than once")
        out[key] = value
    return out


def _finite_float(text: str) -> float | _Bad:
    value = float(text)
    if not math.isfinite(value):
        return _Bad(f"{_shown(text)} is too large for a number")
    return value


def _bounded_int(text: str) -> int | _Bad:
    # Count digits before int(): its cost grows with the square of their number.
    if len(text.lstrip("+-")) > 19 or abs(int(text)) > MAX_INT:
        return _Bad(f"the integer {_shown(text)} is beyond 64 bits")
    return int(text)


def _shown(text: object) -> str:
    """A value for a message, at most about 30 characters (a document's value may be huge)."""
    if isinstance(text, bool) or not isinstance(text, str | int | float):
        return shown(text)
    text = str(text)
    return repr(text if len(text) <= 24 else text[:20] + "...")


def shown(value: object, width: int = 40) -> str:
    """``repr`` of a parsed value for a one-line message, cut to about ``width`` characters.

    Built with :mod:`reprlib`, so a value of a million nested items costs no
    more than a short one (an alias-expanded list never reaches a message whole).
    """
    import reprlib

    short = reprlib.Repr()
    short.maxlevel, short.maxlist, short.maxdict, short.maxstring, short.maxother = 2, 4, 4, 30, 30
    text = " ".join(short.repr(value).split())
    return text if len(text) <= width else text[: width - 3] + "..."


def load_yaml(text: str, where: str = "YAML") -> Any:
    """Parse YAML text: :func:`calibrator.yamlfile.loads` (the one YAML reader).

    Numbers are what :data:`NUMBER` matches, in YAML 1.2 fashion (``1e-3`` is
    a number); ``0x1F``, ``0o17``, ``1_000``, ``1:30``, ``.nan`` and ``.inf``
    are refused, not silently converted; so are duplicate keys, deep nesting
    and alias expansion beyond the reader's limits.

    Raises
    ------
    StrictError
    """
    from calibrator import yamlfile

    return yamlfile.loads(text, where)


def check_budget(what: str, value: float, limit: float, unit: str = "") -> None:
    """Refuse a size or a time above its budget, before anything is allocated or waited for.

    Parameters
    ----------
    what : str
        The option or input (``"--trials"``).
    value, limit : number
        ``value`` must be <= ``limit`` (and not NaN).
    unit : str
        Unit of both, named in the error (``"trials"``, ``"s"``).

    Raises
    ------
    StrictError
        ``--trials: 1000000000000 trials is more than the limit of 1e+09 trials``.
    """
    if not value <= limit:
        unit = f" {unit}" if unit else ""
        where = f"{what}: " if what else ""
        raise StrictError(
            f"{where}{_amount(value)}{unit} is more than the limit of {_amount(limit)}{unit}"
        )


def _amount(value: float) -> str:
    """A number for a message: whole numbers as digits (shortened), others with %g."""
    if isinstance(value, int):
        text = str(value) if abs(value) < 10**30 else f"about 1e{len(str(abs(value))) - 1}"
        return text
    short = f"{value:g}"
    # %g keeps 6 digits: 1000000000001 would read as its own limit 1e+12.
    return short if float(short) == value else repr(float(value))


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
                raise StrictError(f"must be true or false, got {_shown(value)}")
            return value
        if self.kind is str:
            if not isinstance(value, str):
                raise StrictError(f"must be text, got {_shown(value)}")
            if self.choices and value not in self.choices:
                raise StrictError(
                    f"{_shown(value)} is not one of {', '.join(map(repr, self.choices))}"
                )
            return self.parse(value) if self.parse is not None else value
        if self.kind is tuple:
            return self._numbers(value)
        return self._number(value)

    def _number(self, value: Any) -> int | float:
        whole = self.kind is int
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise StrictError(f"must be a {'whole ' if whole else ''}number, got {_shown(value)}")
        if whole and not isinstance(value, int):
            raise StrictError(f"must be a whole number, got {_shown(value)}")
        if not whole:
            if isinstance(value, int) and abs(value) > MAX_INT:
                raise StrictError(f"the number {_amount(value)} is too large")
            value = float(value)
            if not math.isfinite(value):
                raise StrictError(f"must be a finite number, got {value}")
        low_bad = self.low is not None and (
            value <= self.low if self.open_low else value < self.low
        )
        high_bad = self.open_high and self.high is not None and value >= self.high
        if low_bad or high_bad:
            raise StrictError(f"must be {self._span()}, got {_amount(value)}")
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
                raise StrictError(f"needs {self.size} comma-separated numbers, got {_shown(value)}")
            numbers = [parse_number(p, "a coordinate") for p in parts]
        elif isinstance(value, list | tuple) and len(value) == self.size:
            numbers = list(value)
        else:
            raise StrictError(f"needs {self.size} numbers, got {_shown(value)}")
        out = []
        for v in numbers:
            if isinstance(v, bool) or not isinstance(v, int | float):
                raise StrictError(f"needs {self.size} numbers, got {_shown(v)}")
            if self.high is not None and not abs(v) <= self.high:
                raise StrictError(
                    f"{_amount(v)} {self.unit} is beyond +-{self.high:g} {self.unit}".replace(
                        "  ", " "
                    )
                )
            out.append(float(v))
        return tuple(out)
