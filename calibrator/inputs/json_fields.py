"""Numbers and tables of a parsed JSON document, checked for type, shape and size.

A document read by :func:`calibrator.inputs.jsonfile.load_json` holds only
JSON values; a reader then needs its numbers as floats and its tables as
arrays, refused in one line when a value is text, ``true``, a ragged list
or absurdly large.

Use::

    from calibrator.inputs.json_fields import Fields

    check = Fields("cal.json")
    mdh = check.table(doc, "nominal_mdh", (6, 5))   # ndarray (6, 5)
    value = check.number(doc["deltas"]["a2"], "deltas.a2")
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from calibrator.errors import CalibrationError

__all__ = ["MAX_ABS", "Fields"]

#: Largest magnitude of a number of a document: no length (mm) or angle (rad)
#: of an arm comes near it, and products of such numbers stay finite.
MAX_ABS = 1e12


class Fields:
    """The checks of one document's fields, naming the document in every error.

    Parameters
    ----------
    where : str or Path
        The document (a path), named at the start of each error.
    """

    def __init__(self, where: Any) -> None:
        self.where = where

    def number(self, value: Any, what: str) -> float:
        """``value`` as a float: a JSON number, finite, within :data:`MAX_ABS`.

        Raises
        ------
        calibrator.errors.CalibrationError
            ``cal.json: deltas.a2 must be a number, got 'x'``.
        """
        # bool is an int in Python; a JSON true is not a number here.
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise CalibrationError(f"{self.where}: {what} must be a number, got {value!r:.40}")
        if not math.isfinite(value) or abs(value) > MAX_ABS:
            raise CalibrationError(f"{self.where}: {what} is not a finite, sane number")
        return float(value)

    def table(self, doc: dict, key: str, shape: tuple[int, int]) -> np.ndarray:
        """``doc[key]`` as an array of ``shape``: a list of rows of numbers.

        Raises
        ------
        calibrator.errors.CalibrationError
            ``cal.json: 'mdh' must be a 6x5 table of numbers``, or a bad number.
        """
        value = doc.get(key)
        rows, cols = shape
        if (
            not isinstance(value, list)
            or len(value) != rows
            or not all(isinstance(r, list) and len(r) == cols for r in value)
        ):
            raise CalibrationError(
                f"{self.where}: '{key}' must be a {rows}x{cols} table of numbers"
            )
        return np.array(
            [
                [self.number(v, f"{key}[{i}][{j}]") for j, v in enumerate(r)]
                for i, r in enumerate(value)
            ]
        )
