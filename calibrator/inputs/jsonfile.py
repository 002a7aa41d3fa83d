"""Strict JSON: every JSON a user hands in is parsed by :func:`load_json`.

Refused: duplicate keys (Python keeps the last one silently), ``NaN`` and
``Infinity``, numbers that overflow to infinity (``1e400``) and integers
beyond 64 bits (``math.isfinite`` raises ``OverflowError`` on an integer
above about 1e308), nesting too deep. Each refusal is one line naming the
file and the key: a :class:`~calibrator.inputs.errors.StrictError`.

Use::

    from calibrator.inputs import jsonfile

    doc = jsonfile.load_json(text, "calibration.json")
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Callable
from typing import Any

from calibrator.inputs import messages
from calibrator.inputs.errors import StrictError
from calibrator.inputs.grammar import MAX_INT

__all__ = ["first_leaf", "load_json"]


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


def first_leaf(value: Any, test: Callable[[Any], bool], where: str = "") -> tuple[str, Any] | None:
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
        items: Any = value.items()
    elif isinstance(value, list):
        items = enumerate(value)
    else:
        return None
    for key, item in items:
        if isinstance(key, int):
            path = f"{where}[{key}]"
        elif _PLAIN_KEY.fullmatch(key):
            path = f"{where}.{key}" if where else key
        else:  # a key a message cannot show as is (a newline, a dot, nothing): quoted
            path = f"{where}[{key!r}]"
        found = first_leaf(item, test, path)
        if found is not None:
            return found
    return None


def _first_bad(value: Any) -> tuple[str, _Bad] | None:
    """Key path and marker of the first refused number in a parsed document."""
    return first_leaf(value, lambda leaf: isinstance(leaf, _Bad))


def _unique_keys(pairs: list[tuple[str, Any]]) -> dict:
    out: dict = {}
    for key, value in pairs:
        if key in out:
            raise StrictError(f"key {key!r} appears more than once")
        out[key] = value
    return out


def _finite_float(text: str) -> float | _Bad:
    value = float(text)
    if not math.isfinite(value):
        return _Bad(f"{messages.short(text)} is too large for a number")
    return value


def _bounded_int(text: str) -> int | _Bad:
    # Count digits before int(): its cost grows with the square of their number.
    if len(text.lstrip("+-")) > 19 or abs(int(text)) > MAX_INT:
        return _Bad(f"the integer {messages.short(text)} is beyond 64 bits")
    return int(text)
