"""The one number grammar: every number a user writes is read here.

:func:`parse_number` accepts decimal numbers only
(``[+-]digits[.digits][e[+-]digits]``). Python's ``float()`` also takes
``0_5`` (as 5.0), ``nan``, ``inf`` and ``infinity``; pandas and YAML 1.1
take hex, octal and ``1:30``. None of those is a joint angle or a length.
The JSON and YAML readers (:mod:`~calibrator.inputs.jsonfile`,
:mod:`~calibrator.inputs.yamlfile`) read their numbers in this grammar too.

Every refusal is a :class:`~calibrator.inputs.errors.StrictError`: one line,
exit code 2 at the CLI.

Use::

    from calibrator.inputs import grammar

    grammar.parse_number("0.25")            # 0.25; "0_5", "0x1", "nan" raise
    grammar.parse_columns(rows, ("q1_rad", "q2_rad"), "plan.csv")
"""

from __future__ import annotations

import math
import re
from typing import Any

import numpy as np

from calibrator.inputs import messages
from calibrator.inputs.errors import StrictError

__all__ = ["MAX_INT", "NUMBER", "parse_columns", "parse_number", "parse_numbers"]

#: Largest integer magnitude a file may hold: int64 (seeds, counts, pose numbers).
MAX_INT = 2**63 - 1
#: The number grammar: optional sign, digits with an optional fraction (or a
#: fraction alone), optional exponent. ASCII digits only (\\d would take any
#: script's digits, as float() does). No underscores, no hex, no words.
NUMBER = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
#: Longest text read as one number (a double needs 17 significant digits).
_MAX_NUMBER_CHARS = 64


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
        raise StrictError(f"{what}: {messages.short(s)} is not a decimal number")
    value = float(s)
    if not math.isfinite(value):
        raise StrictError(f"{what}: {messages.short(s)} is too large for a number")
    return value


def parse_numbers(cells: Any, what: str = "value") -> np.ndarray:
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
