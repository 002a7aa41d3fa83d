"""What every language module builds on: the job, units, targets, Language and its table.

Also the helpers that read a program's lines. A language module subclasses
:class:`Language` and registers it with :func:`language`;
:mod:`calibrator.languages` imports every language module, so the table is
full once the package is imported.
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from calibrator import outputs
from calibrator.errors import CalibrationError
from calibrator.languages import registry


class FilterError(CalibrationError):
    """A program the filter cannot read (one line naming the file and line)."""


@dataclass(frozen=True)
class Layout:
    """How a target's numbers encode it.

    Attributes
    ----------
    kind : str
        ``"pose"`` or ``"joints"``.
    units : tuple of str
        Unit of each number (keys of :data:`calibrator.languages.numbers.RESOLUTION`).
    decode : callable
        ``decode(values (N, m)) -> (N, 4, 4)`` pose in the target's frame (mm)
        or ``(N, 6)`` controller joints (rad).
    encode : callable
        ``encode(new, old_values (N, m)) -> (N, m)``: the numbers of a new pose
        or joint vector, in the form closest to the old numbers.
    """

    kind: str
    units: tuple
    decode: Callable[[np.ndarray], np.ndarray]
    encode: Callable[[np.ndarray, np.ndarray], np.ndarray]


@dataclass(slots=True)
class Target:
    """One target of a program, where its numbers are and what it means.

    Attributes
    ----------
    file : str
    line : int
        1-based line of its first number.
    label : str
        The program's name for it (``XP3``, ``P[12]``, ``movel``).
    layout : Layout
    tokens : list of str
        Its numbers as written, in the layout's order.
    spans : list of (int, int, int)
        ``(line index in its unit, start, end)`` of each token.
    tool, base : ndarray, shape (4, 4), or None
        ``flange2tool`` (on the controller's flange, tool 0) and ``base2frame``
        (the controller's base frame, base 0, to the frame the pose is written
        in), mm; None is the identity (tool 0, base 0).
    code : tuple of int or None
        The configuration the program states (language-specific), None for
        "the solution nearest the previous target".
    mark_line : int
        Unit line index where a ``--keep-failed`` mark goes.
    problem : str or None
        Why the target cannot be corrected at all (a partial aggregate, a
        frame nobody defines): it fails with this reason, unsolved.
    """

    file: str
    line: int
    label: str
    layout: Layout
    tokens: list
    spans: list
    tool: Any = None
    base: Any = None
    code: tuple | None = None
    mark_line: int = 0
    problem: str | None = None


@dataclass(slots=True)
class Unit:
    """Consecutive lines of a program (each with its line ending) and the targets in them."""

    lines: list
    targets: list = field(default_factory=list)


@dataclass
class Job:
    """What the user asked for (shared by every language).

    Attributes
    ----------
    calibration : calibrator.calibration.Calibration
    frames : calibrator.languages.frames_file.FrameTable
    limits : ndarray, shape (6, 2), or None
        Joint limits of the model (rad).
    correct_joints : bool
        ``--joint-targets correct``.
    max_mm, max_deg : float
        ``--max-correction``.
    keep_failed : bool
    payload_kg : float or None
    config_dat : Path or None
        KUKA ``$config.dat`` holding ``TOOL_DATA`` / ``BASE_DATA``.
    convention : calibrator.robots.JointConvention
    controller_base, controller_flange : ndarray, shape (4, 4), or None
        The controller's base (world) frame in the model's base frame (MDH
        frame 0) and its flange (tool 0) on the model's flange, mm
        (:attr:`calibrator.robots.RobotDescription.model_base2controller_base`,
        ``model_flange2controller_flange``): every frame a program names
        (base 0, tool 0, user frames, work objects, tools) is the
        controller's, relative to these. None: the calibration's arm's.
    """

    calibration: Any
    frames: Any
    limits: Any = None
    correct_joints: bool = False
    max_mm: float = 5.0
    max_deg: float = 0.5
    keep_failed: bool = False
    payload_kg: float | None = None
    config_dat: Path | None = None
    convention: Any = None
    controller_base: Any = None
    controller_flange: Any = None


class Language:
    """Base of every language: reading, configuration data, marks."""

    name = ""
    #: Comment opener for a ``--keep-failed`` mark; None where the language has no line comment.
    comment: str | None = None

    def __init__(self, job: Job, program: Path) -> None:
        self.job = job
        self.program = Path(program)

    def files(self, output: Path) -> list[tuple[Path, Path]]:
        """``(input, output)`` pairs to filter, in order (KRL: the ``.dat`` and the ``.src``)."""
        return [(self.program, Path(output))]

    def scan(self, path: Path) -> Iterator[Unit]:
        """The units of one file, in order; every line exactly once."""
        raise NotImplementedError

    def code(self, q_deg: np.ndarray, bits: np.ndarray) -> np.ndarray:
        """Configuration data (N, k) the language would state for controller joints (deg)."""
        raise NotImplementedError

    def code_bits(self, code: np.ndarray) -> np.ndarray:
        """The geometric bits (N, 3) a stated configuration (N, k) implies."""
        raise NotImplementedError

    def describe(self, code: tuple) -> str:
        """A configuration as the language writes it (``S 6 T 35``)."""
        return str(tuple(code))


def language(name: str, suffixes: tuple, help: str) -> Callable:
    """Register a :class:`Language` subclass as ``name`` (programs ending in ``suffixes``).

    It becomes the reader of the language's entry in
    :data:`calibrator.languages.registry.LANGUAGES`.
    """

    def register(cls: type[Language]) -> type[Language]:
        cls.name = name
        registry.reader(name, suffixes, help, cls)
        return cls

    return register


def choose(fmt: str | None, program: str | os.PathLike) -> str:
    """The language of ``program``: ``fmt`` if given (it must fit the extension), else by suffix."""
    return outputs.choose_format(registry.readers(), fmt, program)


def numbered_frame(job: Job, kind: str, number: int) -> Any:
    """Frame ``number`` (4, 4) of ``kind`` (``"tool"`` or ``"base"``) from ``--frames``, or None.

    Number 0 is the controller's flange (tool) or its base or world frame
    (base) itself, as on KUKA, Fanuc and Yaskawa controllers; every frame is
    given relative to those (the engine places them on the model,
    :attr:`Job.controller_base`).
    """
    if number == 0:
        return np.eye(4)
    table = job.frames.tools if kind == "tool" else job.frames.bases
    return table.get(str(number))


def target_tool(job: Job, joints: bool, found: tuple[Any, str | None]) -> tuple[Any, str | None]:
    """``(tool, problem)`` of a target from its frame look-up ``found``.

    A joint target kept as taught (no ``--joint-targets correct``) needs no
    tool: a program that moves only in joints may define none, and its targets
    are kept, not failed, whatever frame is (or is not) active.
    """
    tool, problem = found
    if joints and not job.correct_joints and problem is not None:
        return np.eye(4), None
    return tool, problem


def read_lines(path: Path) -> Iterator[tuple[int, str]]:
    """``(1-based number, text with its ending)`` of each line, bytes kept as they are.

    Read as Latin-1 so every byte maps to one character and back: UTF-8 or
    Windows-1252 comments are written back unchanged, and every keyword the
    readers look for is ASCII.
    """
    for first, lines in read_chunks(path):
        yield from enumerate(lines, start=first)


def read_chunks(path: Path, size: int = 1 << 20) -> Iterator[tuple[int, list[str]]]:
    """``(number of the first line, lines)`` of about ``size`` characters at a time.

    As :func:`read_lines`, for a reader that can skip a run of lines it has
    no use for with one search over their text.
    """
    try:
        with open(path, encoding="latin-1", newline="") as fh:
            first = 1
            while lines := fh.readlines(size):
                if _BINARY.search("".join(lines)) is not None:
                    # The lines before the first binary one are read, as one by one.
                    k, bad = next(
                        (k, b) for k, line in enumerate(lines) if (b := _BINARY.search(line))
                    )
                    if k:
                        yield first, lines[:k]
                    raise FilterError(
                        f"{path}:{first + k}: binary bytes (control character {bad.group()!r}): "
                        "not a program text"
                    )
                yield first, lines
                first += len(lines)
    except OSError as exc:
        raise FilterError(f"{path}: cannot read ({exc.strerror})") from None


#: Control characters no program text holds (tab, line and page breaks and DOS's
#: end-of-file mark Ctrl-Z excepted): a file with them is binary, not a program.
_BINARY = re.compile("[\x00-\x08\x0e-\x19\x1b-\x1f\x7f]")


def split_ending(line: str) -> tuple[str, str]:
    """A line's text and its ending (``\\r\\n``, ``\\n``, ``\\r`` or nothing)."""
    body = line.rstrip("\r\n")
    return body, line[len(body) :]
