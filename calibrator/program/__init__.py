"""The plan as a robot program, one writer per controller language.

A format is one function registered with :func:`writer`: it takes a
:class:`ProgramSpec` and returns the program's text. The CLI's ``--format``
choices and the file-extension lookup come from :data:`REGISTRY`; importing
this package imports every writer module, which registers its functions.

Every program does the same thing: a joint move to the safe home pose, then
for each plan pose in order a joint move (exact stop) and a dwell long enough
for the tracker's readings (with an optional digital-output pulse at arrival),
and a joint move back home. Speeds never exceed the plan's cap.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from calibrator import outputs
from calibrator.program.spec import PULSE_S, ProgramSpec, move_duration_s

__all__ = [
    "REGISTRY",
    "Format",
    "ProgramSpec",
    "between_homes",
    "choose",
    "degrees",
    "move_duration_s",
    "name_for",
    "render",
    "title",
    "writer",
]


@dataclass(frozen=True)
class Format:
    """A registered program format: name, file suffixes, one-line help, writer, naming rule.

    ``program_name(stem)`` turns the file name before its first dot into the
    program's name by the language's rules (:mod:`calibrator.program.names`),
    or raises :class:`~calibrator.errors.CalibrationError`.
    """

    name: str
    suffixes: tuple
    help: str
    write: Callable[[ProgramSpec], str]
    program_name: Callable[[str], str] | None = None


#: name -> Format, in registration order.
REGISTRY: dict[str, Format] = {}


def writer(
    name: str, suffixes: tuple, help: str, naming: Callable[[str], str] | None = None
) -> Callable:
    """Register ``func(spec) -> str`` as program format ``name`` (files ending in ``suffixes``).

    ``naming(stem)`` is the language's naming rule (None: the program has no name).
    """

    def register(func: Callable[[ProgramSpec], str]) -> Callable[[ProgramSpec], str]:
        REGISTRY[name] = Format(name, tuple(suffixes), help, func, naming)
        return func

    return register


def name_for(fmt: str, output: str | os.PathLike) -> str:
    """The program name a file ``output`` of format ``fmt`` gets (its name before the first dot).

    Raises
    ------
    CalibrationError
        The language cannot name a program so (see :mod:`calibrator.program.names`).
    """
    outputs.known_format(REGISTRY, fmt)
    stem = os.path.basename(os.fspath(output)).split(".")[0]
    naming = REGISTRY[fmt].program_name
    return "calibrator_measure" if naming is None else naming(stem)


def choose(fmt: str | None, output: str | os.PathLike) -> str:
    """The format to write: ``fmt`` if given (it must fit the extension), else by extension.

    Raises
    ------
    CalibrationError
        Unknown format, an extension no format has, or a mismatch.
    """
    return outputs.choose_format(REGISTRY, fmt, output)


def render(spec: ProgramSpec, fmt: str) -> str:
    """The program text of ``spec`` in format ``fmt``."""
    outputs.known_format(REGISTRY, fmt)
    return REGISTRY[fmt].write(spec)


def degrees(q_rad: ArrayLike) -> np.ndarray:
    """Joint angles in degrees (the unit of KRL, RAPID and Fanuc LS)."""
    return np.degrees(np.asarray(q_rad, dtype=float))


def title(spec: ProgramSpec) -> str:
    """The header line every program opens with: its poses, and the model when known."""
    model = f" of a {spec.model}" if spec.model else ""
    return f"{len(spec.plan_rad)} poses for a laser-tracker calibration{model}"


def between_homes(
    spec: ProgramSpec,
    move: Callable[[str, int, np.ndarray, np.ndarray], str],
    pulse: Callable[[int], list[str]],
    dwell: Callable[[float], str],
    *,
    comment: Callable[[str], str] | None = None,
    pulse_blocks: bool = False,
) -> list[str]:
    """The statements between the first and the last home move, in every language.

    Per via (moved through on the path the plan checked in the cell) its move
    alone; per pose its move, the pulse if asked and the dwell. Each language
    gives its own statements.

    Parameters
    ----------
    spec : ProgramSpec
    move : callable
        ``move(kind, pose, start_rad, end_rad)`` (``kind`` ``"via"`` or ``"pose"``,
        joints shape (6,), rad): the joint move statement.
    pulse : callable
        ``pulse(output)``: the statements pulsing the digital output for :data:`PULSE_S`.
    dwell : callable
        ``dwell(seconds)``: the wait statement.
    comment : callable, optional
        ``comment(text)``: a comment line, written before each move
        (``via before pose i`` or ``pose i``); None: no comments.
    pulse_blocks : bool
        The pulse statements wait out the pulse, so the dwell is that much shorter.

    Returns
    -------
    list of str
    """
    lines: list[str] = []
    for kind, pose, start, end in spec.moves()[1:-1]:
        assert pose is not None  # only the home moves have no pose
        if comment is not None:
            lines.append(comment(f"via before pose {pose}" if kind == "via" else f"pose {pose}"))
        lines.append(move(kind, pose, start, end))
        if kind == "via":
            continue  # no dwell, no pulse
        wait = spec.dwell_s
        if spec.pulse_output is not None:
            lines += pulse(spec.pulse_output)
            if pulse_blocks:
                wait -= PULSE_S
        lines.append(dwell(wait))
    return lines


# Importing the writer modules registers them (order = order of --format choices).
from calibrator.program import urscript as _urscript  # noqa: E402,F401  isort: skip
from calibrator.program import krl as _krl  # noqa: E402,F401  isort: skip
from calibrator.program import rapid as _rapid  # noqa: E402,F401  isort: skip
from calibrator.program import fanuc as _fanuc  # noqa: E402,F401  isort: skip
from calibrator.program import table as _table  # noqa: E402,F401  isort: skip
