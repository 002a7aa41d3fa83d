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
    tok = np.asarray(tokens, dtype=str)
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
    out = [list(row) for row in tokens]
    for i, j in zip(*np.nonzero(~same | ~plain), strict=True):
        if plain[i, j]:
            text = f"{new[i, j]:.{places[i, j]}f}"
            if text.startswith("-") and float(text) == 0.0:
                text = text[1:]
            if tokens[i][j].startswith("+") and not text.startswith("-"):
                text = "+" + text
            out[i][j] = text
        else:
            out[i][j] = write(tokens[i][j], float(new[i, j]), units[j])
    return out
