"""The one table of robot languages and the two decorators that fill it.

An entry is a language: what ``calibrator program`` writes in it (a
:class:`Writer`, or None) and what ``calibrator compensate`` reads of it (a
:class:`Reader`, or None). A writer module registers its function with
:func:`writer`; a reader module registers its class with
:func:`calibrator.languages.reading.language`, which calls :func:`reader`;
both fill the same entry. :mod:`calibrator.languages` imports every
language, so the table is full once the package is imported.

Each side keeps its own ``--format`` name, file suffixes and help, as the
two commands have always shown them (``program --format fanuc-ls`` writes
``.ls`` files, ``compensate --format fanuc`` reads them; a RAPID program is
read from ``.mod``, ``.prg`` or ``.modx`` but written as ``.mod``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from calibrator.languages.spec import ProgramSpec

__all__ = ["LANGUAGES", "Entry", "Reader", "Writer", "reader", "readers", "writer", "writers"]


@dataclass(frozen=True)
class Writer:
    """A language as ``calibrator program`` writes it: format name, file suffixes, help, writer.

    ``write(spec)`` is the program's text. ``program_name(stem)`` turns the
    file name before its first dot into the program's name by the language's
    rules (:mod:`calibrator.languages.names`), or raises
    :class:`~calibrator.errors.CalibrationError`; None: the program has no name.
    """

    name: str
    suffixes: tuple
    help: str
    write: Callable[[ProgramSpec], str]
    program_name: Callable[[str], str] | None = None


@dataclass(frozen=True)
class Reader:
    """A language as ``calibrator compensate`` reads it: format name, file suffixes, help, class.

    ``cls(job, program)`` is the :class:`~calibrator.languages.reading.Language`
    that reads one program.
    """

    name: str
    suffixes: tuple
    help: str
    cls: type


@dataclass
class Entry:
    """One robot language: its writer and its reader, either of them None."""

    name: str
    writer: Writer | None = None
    reader: Reader | None = None


#: Language name -> Entry, in registration order.
LANGUAGES: dict[str, Entry] = {}


def _entry(language: str) -> Entry:
    return LANGUAGES.setdefault(language, Entry(language))


def writer(
    name: str,
    suffixes: tuple,
    help: str,
    naming: Callable[[str], str] | None = None,
    language: str | None = None,
) -> Callable:
    """Register ``func(spec) -> str`` as program format ``name`` (files ending in ``suffixes``).

    ``naming(stem)`` is the language's naming rule (None: the program has no
    name). ``language`` is the entry it fills (default: ``name``).
    """

    def register(func: Callable[[ProgramSpec], str]) -> Callable[[ProgramSpec], str]:
        _entry(language or name).writer = Writer(name, tuple(suffixes), help, func, naming)
        return func

    return register


def reader(name: str, suffixes: tuple, help: str, cls: type) -> None:
    """Register the reader class ``cls`` of language ``name`` (programs ending in ``suffixes``)."""
    _entry(name).reader = Reader(name, tuple(suffixes), help, cls)


def writers() -> dict[str, Writer]:
    """``program``'s format name -> :class:`Writer`, in registration order."""
    return {e.writer.name: e.writer for e in LANGUAGES.values() if e.writer is not None}


def readers() -> dict[str, Reader]:
    """``compensate``'s format name -> :class:`Reader`, in registration order."""
    return {e.reader.name: e.reader for e in LANGUAGES.values() if e.reader is not None}
