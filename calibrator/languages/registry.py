"""The table of program formats and the decorator that fills it.

Each writer module registers its function with :func:`writer`; the package
(:mod:`calibrator.languages`) imports every writer module, so the table is
full once the package is imported.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from calibrator.languages.spec import ProgramSpec

__all__ = ["REGISTRY", "Format", "writer"]


@dataclass(frozen=True)
class Format:
    """A registered program format: name, file suffixes, one-line help, writer, naming rule.

    ``program_name(stem)`` turns the file name before its first dot into the
    program's name by the language's rules (:mod:`calibrator.languages.names`),
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
