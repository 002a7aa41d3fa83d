"""A program's name from its file name, by each language's rules, or a refusal.

KUKA's KSS loads a ``.src`` only when its ``DEF`` name is the file's name, and
Fanuc's ``/PROG`` name is the program's name on the pendant: for those the
file name must already be a valid name, not a keyword nor a name the program
uses (``PTP``, ``END``), or it is refused (nothing is renamed behind the
user's back). URScript and RAPID do not tie the name to the file: an
unusable character becomes ``_``, and a keyword or a name the program itself
calls gets ``_program`` appended (``end.script`` holds ``def end_program():``,
``movej.script`` no procedure that shadows the ``movej`` it calls).
"""

from __future__ import annotations

import re

from calibrator.errors import CalibrationError

_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]*")


def program_name(
    stem: str,
    *,
    language: str,
    reserved: frozenset[str],
    max_length: int,
    same_as_file: bool,
    case_sensitive: bool = False,
) -> str:
    """The program name for a file whose name before its first dot is ``stem``.

    Parameters
    ----------
    stem : str
    language : str
        Named in the refusal (``"KRL"``).
    reserved : frozenset of str
        Keywords and the names the program uses; compared in upper case unless
        ``case_sensitive``.
    max_length : int
        Longest name the language takes.
    same_as_file : bool
        The controller requires the name to be the file's: refuse rather than rename
        (otherwise a reserved name gets ``_program`` appended).
    case_sensitive : bool

    Returns
    -------
    str

    Raises
    ------
    CalibrationError
        One line naming the file name and what the language needs.
    """
    if same_as_file:
        name = stem
        if not _NAME.fullmatch(name) or len(name) > max_length:
            raise CalibrationError(
                f"{stem!r}: {language} names the program after its file, so the file name "
                f"must be a {language} name: a letter, then letters, digits or _, at most "
                f"{max_length} characters"
            )
    else:
        name = re.sub(r"[^A-Za-z0-9_]", "_", stem) or "calibrator_measure"
        if not name[0].isalpha():
            name = f"p_{name}"
        if len(name) > max_length:
            raise CalibrationError(
                f"{stem!r}: a {language} name has at most {max_length} characters: "
                "choose a shorter file name"
            )
    if taken(name, reserved, case_sensitive):
        if same_as_file:
            raise CalibrationError(
                f"{stem!r}: {name} is a {language} keyword or a name the program uses: "
                "choose another file name"
            )
        name = f"{name}_program"  # free to differ from the file's name: never a keyword
    return name


def taken(name: str, reserved: frozenset[str], case_sensitive: bool = False) -> bool:
    """Whether ``name`` is one of ``reserved`` (upper-cased unless ``case_sensitive``)."""
    return (name if case_sensitive else name.upper()) in reserved


def words(text: str, *, upper: bool = True) -> frozenset[str]:
    """The whitespace-separated words of ``text`` (upper-cased unless ``upper`` is False)."""
    return frozenset(w.upper() if upper else w for w in text.split())
