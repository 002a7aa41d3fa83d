"""Numbers written back into a program: the original's look, the correction's value.

A corrected value is printed with as many decimals as the original token
had; one more only where rounding to those would miss the corrected value by
more than the field's resolution (:data:`RESOLUTION`). A value that reads
the same as the original keeps the original token byte for byte (so ``1E3``,
``+5`` or ``-0.0`` survive a calibration equal to its nominal model).
"""

from __future__ import annotations

import re

#: How close a written value must be to the computed one, per field unit.
#: Well inside what a corrected target must achieve (0.05 mm, 0.01 deg).
RESOLUTION = {
    "mm": 0.005,
    "m": 5e-6,
    "deg": 0.0005,
    "rad": 5e-6,
    "quat": 5e-6,
    "pulse": 0.5,
}

#: A decimal number as programs write them (no thousands separators).
NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")


def decimals(token: str) -> int:
    """Digits after the decimal point of a token (0 without one)."""
    mantissa = re.split("[eE]", token)[0]
    return len(mantissa.split(".")[1]) if "." in mantissa else 0


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
    if abs(float(text) - value) > RESOLUTION[unit]:
        text = f"{value:.{places + 1}f}"
    if float(text) == float(token):
        return token
    if text.startswith("-") and float(text) == 0.0:
        text = text[1:]  # no "-0.000" from a value that rounds to zero
    if token.startswith("+") and not text.startswith("-"):
        text = "+" + text
    return text
