"""Numbers written back into a program: the original's look, the correction's value.

A corrected value is printed with as many decimals as the original token
had; more (one at a time, at most :data:`MAX_EXTRA`) only where rounding to
those would miss the corrected value by more than the field's resolution
(:data:`RESOLUTION`): a joint printed ``45.0`` and corrected by 0.023 deg is
written ``45.0230`` if it must be, never rounded back to ``45.0``. A value that reads
the same as the original keeps the original token byte for byte (so ``1E3``,
``+5`` or ``-0.0`` survive a calibration equal to its nominal model).
"""

from __future__ import annotations

import math
import re

import numpy as np

#: How close a written value must be to the computed one, per field unit.
#: Well inside what a corrected target must achieve (0.05 mm, 0.01 deg).
RESOLUTION = {
    "mm": 0.005,
    "m": 5e-6,
    "deg": 0.0001,  # 0.002 mm at 1.3 m from the axis
    "rad": 2e-6,
    "quat": 1e-6,
    "pulse": 0.5,
}

#: Most decimals added to a token to reach the resolution.
MAX_EXTRA = 4

#: A decimal number as programs write them (no thousands separators).
NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")


def problem(token: str) -> str | None:
    """Why ``token`` (one field of a target, stripped) is not a number; None if it is one.

    The one grammar every language reader applies to the fields it reads: a
    field is a whole :data:`NUMBER` with a finite value, or its target fails.
    Finding numbers *inside* a field instead (``1.2.3`` read as ``1.2`` and
    ``.3``) shifts every later column: the Z becomes a rotation.
    """
    if token == "":
        return "an empty number"
    if NUMBER.fullmatch(token) is None:
        return f"{_shown(token)} is not a number"
    if not math.isfinite(float(token)):
        return f"{_shown(token)} is not a finite number"
    return None


def fields(text: str, offset: int = 0, separators: str = ",") -> list[tuple[str, int, int]]:
    """The fields of ``text`` between ``separators``, stripped, as ``(token, start, end)``.

    ``start`` and ``end`` index the line ``text`` was cut from (``offset`` is
    where ``text`` starts in it). An empty field (``1,,3``) is kept as an
    empty token, so that :func:`problem` names it.
    """
    out, begin = [], 0
    for i, ch in enumerate(text + separators[0]):
        if ch in separators:
            part = text[begin:i]
            lead = len(part) - len(part.lstrip())
            token = part.strip()
            start = offset + begin + lead
            out.append((token, start, start + len(token)))
            begin = i + 1
    return out


def first_problem(tokens: list) -> str | None:
    """The :func:`problem` of the first token of ``tokens`` (str or ``(str, ...)``) that has one."""
    for token in tokens:
        text = token if isinstance(token, str) else token[0]
        if PLAIN.fullmatch(text) is None:  # the usual token needs no further look
            why = problem(text)
            if why is not None:
                return why
    return None


#: A number no float() can make infinite: no exponent, at most 40 digits.
PLAIN = re.compile(r"[+-]?(?:\d{1,20}(?:\.\d{0,20})?|\.\d{1,20})")
#: :data:`PLAIN`'s grammar with possessive quantifiers, for longer patterns: it matches
#: the same text and never gives digits back, so a line that does not fit fails sooner.
PLAIN_POSSESSIVE = r"[+-]?+(?:\d{1,20}+(?:\.\d{0,20}+)?+|\.\d{1,20}+)"


def _shown(token: str) -> str:
    """A token for a one-line message: quoted, control characters escaped, at most 40 long."""
    text = token if len(token) <= 40 else token[:37] + "..."
    return repr(text)


def decimals(token: str) -> int:
    """Digits after the decimal point of a token (0 without one)."""
    dot = token.find(".")
    if dot < 0:
        return 0
    end = len(token)
    for mark in "eE":
        at = token.find(mark)
        if at >= 0:
            end = at
    return end - dot - 1


def write(token: str, value: float, unit: str) -> str:
    """The text to put in place of ``token`` for the corrected ``value``.

    Parameters
    ----------
    token : str
        The original number as the program wrote it.
    value : float
        The corrected value, in the token's unit.
    unit : str
        A key of :data:`RESOLUTION`; ``pulse`` values are integers.
    """
    if unit == "pulse":
        text = str(int(round(value)))
        return token if int(float(token)) == int(text) else text
    places = decimals(token)
    text = f"{value:.{places}f}"
    for extra in range(1, MAX_EXTRA + 1):
        if abs(float(text) - value) <= RESOLUTION[unit]:
            break
        text = f"{value:.{places + extra}f}"
    if float(text) == float(token):
        return token
    if text.startswith("-") and float(text) == 0.0:
        text = text[1:]  # no "-0.000" from a value that rounds to zero
    if token.startswith("+") and not text.startswith("-"):
        text = "+" + text
    return text


def write_many(tokens: list, old: np.ndarray, new: np.ndarray, units: tuple) -> list:
    """:func:`write` for a block of targets of one layout, vectorised where it can be.

    Parameters
    ----------
    tokens : list of list of str, shape (N, m)
    old, new : ndarray, shape (N, m)
        The values the tokens hold, and the corrected values.
    units : tuple of str, length m

    Returns
    -------
    list of list of str
        The text for each token (the token itself where it reads the same).
    """
    m = len(units)
    flat = [t for row in tokens for t in row]  # numpy reads a flat list faster than a nested one
    tok = np.array(flat, dtype=str).reshape(-1, m)
    plain = ~(np.char.count(tok, "e") + np.char.count(tok, "E")).astype(bool)
    dot = np.char.find(tok, ".")
    places = np.where(dot >= 0, np.char.str_len(tok) - dot - 1, 0)
    res = np.array([RESOLUTION[u] for u in units])
    pulse = np.array([u == "pulse" for u in units])
    rounded = np.round(new * 10.0**places) / 10.0**places
    for _ in range(MAX_EXTRA):
        more = (np.abs(rounded - new) > res) & ~pulse
        if not more.any():
            break
        places = np.where(more, places + 1, places)
        rounded = np.round(new * 10.0**places) / 10.0**places
    same = (rounded == old) | ~np.isfinite(new)
    cells = np.empty(len(flat), dtype=object)
    cells[:] = flat
    out = cells.reshape(-1, m)
    # Tokens with an exponent: one at a time, by :func:`write` (rare).
    for i, j in zip(*np.nonzero(~plain), strict=True):
        out[i, j] = write(tokens[i][j], float(new[i, j]), units[j])
    # Plain tokens that read differently: printed with their decimals, in one pass
    # ("%.*f" rounds as f"{v:.{d}f}" does); the few that print as "-0.0..." or were
    # written with a "+" are then fixed one by one.
    rows, cols = np.nonzero(~same & plain)
    values, digits = new[rows, cols], places[rows, cols]
    texts = list(map("%.*f".__mod__, zip(digits.tolist(), values.tolist(), strict=True)))
    for k in np.flatnonzero(np.signbit(values) & (np.abs(values) < 10.0**-digits)).tolist():
        if float(texts[k]) == 0.0:
            texts[k] = texts[k][1:]  # no "-0.000" from a value that rounds to zero
    for k in np.flatnonzero(np.strings.startswith(tok[rows, cols], "+")).tolist():
        if texts[k][0] != "-":
            texts[k] = "+" + texts[k]
    changed = np.empty(len(texts), dtype=object)
    changed[:] = texts
    out[rows, cols] = changed
    return out.tolist()
