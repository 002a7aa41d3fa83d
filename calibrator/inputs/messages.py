"""Values as one-line messages show them: cut short, whatever their size.

A value read from a user's file may be huge (a million-item list after
alias expansion, a 5,000-character key); a refusal shows at most a few
dozen characters of it.
"""

from __future__ import annotations

from typing import Any

__all__ = ["a_or_an", "amount", "short", "shown"]


def short(text: Any) -> str:
    """A value for a message, at most about 30 characters (a document's value may be huge)."""
    if isinstance(text, bool) or not isinstance(text, str | int | float):
        return shown(text)
    text = str(text)
    return repr(text if len(text) <= 24 else text[:20] + "...")


def shown(value: Any, width: int = 40) -> str:
    """``repr`` of a parsed value for a one-line message, cut to about ``width`` characters.

    Built with :mod:`reprlib`, so a value of a million nested items costs no
    more than a short one (an alias-expanded list never reaches a message whole).
    """
    import reprlib

    cut = reprlib.Repr()
    cut.maxlevel, cut.maxlist, cut.maxdict, cut.maxstring, cut.maxother = 2, 4, 4, 30, 30
    text = " ".join(cut.repr(value).split())
    return text if len(text) <= width else text[: width - 3] + "..."


def amount(value: float) -> str:
    """A number for a message: whole numbers as digits (shortened), others with %g."""
    if isinstance(value, int):
        text = str(value) if abs(value) < 10**30 else f"about 1e{len(str(abs(value))) - 1}"
        return text
    text = f"{value:g}"
    # %g keeps 6 digits: 1000000000001 would read as its own limit 1e+12.
    return text if float(text) == value else repr(float(value))


def a_or_an(name: str) -> str:
    """``name`` with its article, as spoken: ``an abb-irb4600-60-205``, ``a ur10e``, ``a kuka-...``.

    Arm names are read letter by letter or as words; those starting with
    a, e, i or o take "an" (ABB, ER10L, IRB), the rest "a" (UR is "you-are").
    """
    text = str(name)
    return f"{'an' if text[:1].lower() in 'aeio' and text[:1] else 'a'} {text}"
