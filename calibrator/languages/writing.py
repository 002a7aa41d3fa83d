"""The plan as a robot program: choose a format, name the program, render it.

A format is one function registered with :func:`writer`: it takes a
:class:`ProgramSpec` and returns the program's text. The CLI's ``--format``
choices and the file-extension lookup come from :func:`writers` (the
writing side of :data:`calibrator.languages.registry.LANGUAGES`); importing
:mod:`calibrator.languages` imports every writer module, which registers its
functions.

Every program does the same thing: a joint move to the safe home pose, then
for each plan pose in order a joint move (exact stop) and a dwell long enough
for the tracker's readings (with an optional digital-output pulse at arrival),
and a joint move back home. Speeds never exceed the plan's cap.
"""

from __future__ import annotations

import os

import numpy as np
from numpy.typing import ArrayLike

from calibrator import outputs
from calibrator.errors import CalibrationError
from calibrator.languages.path_program import PathSpec
from calibrator.languages.registry import Writer, writer, writers
from calibrator.languages.spec import ProgramSpec, move_duration_s
from calibrator.languages.statements import between_homes, title

__all__ = [
    "PathSpec",
    "ProgramSpec",
    "Writer",
    "between_homes",
    "choose",
    "degrees",
    "move_duration_s",
    "name_for",
    "render",
    "render_path",
    "title",
    "writer",
    "writers",
]


def name_for(fmt: str, output: str | os.PathLike) -> str:
    """The program name a file ``output`` of format ``fmt`` gets (its name before the first dot).

    Raises
    ------
    CalibrationError
        The language cannot name a program so (see :mod:`calibrator.languages.names`).
    """
    table = writers()
    outputs.known_format(table, fmt)
    stem = os.path.basename(os.fspath(output)).split(".")[0]
    naming = table[fmt].program_name
    return "calibrator_measure" if naming is None else naming(stem)


def choose(fmt: str | None, output: str | os.PathLike) -> str:
    """The format to write: ``fmt`` if given (it must fit the extension), else by extension.

    Raises
    ------
    CalibrationError
        Unknown format, an extension no format has, or a mismatch.
    """
    return outputs.choose_format(writers(), fmt, output)


def render(spec: ProgramSpec, fmt: str) -> str:
    """The program text of ``spec`` in format ``fmt``."""
    table = writers()
    outputs.known_format(table, fmt)
    return table[fmt].write(spec)


def degrees(q_rad: ArrayLike) -> np.ndarray:
    """Joint angles in degrees (the unit of KRL, RAPID and Fanuc LS)."""
    return np.degrees(np.asarray(q_rad, dtype=float))


def _path_writers() -> dict:
    """The path program writer of each format (:mod:`calibrator.languages.path_program`)."""
    from calibrator.languages.fanuc import writer as fanuc
    from calibrator.languages.krl import writer as krl
    from calibrator.languages.rapid import writer as rapid
    from calibrator.languages.urscript import writer as urscript

    return {
        "urscript": urscript.write_path,
        "krl": krl.write_path,
        "rapid": rapid.write_path,
        "fanuc-ls": fanuc.write_path,
    }


def render_path(spec: PathSpec, fmt: str) -> str:
    """The path program text of ``spec`` in format ``fmt`` (every format :func:`writers` lists).

    Raises
    ------
    CalibrationError
        A format that writes no path program, or a spec the language cannot state.
    """
    outputs.known_format(writers(), fmt)
    table = _path_writers()
    if fmt not in table:
        raise CalibrationError(f"{fmt} writes no path programs (only {', '.join(table)})")
    return table[fmt](spec)
