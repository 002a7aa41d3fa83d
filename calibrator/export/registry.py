"""The table of export formats and the decorator that fills it.

Each format module registers its writer with :func:`exporter`; the package
(:mod:`calibrator.export`) imports every format module, so the table is
full once the package is imported.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from calibrator.calibration import Calibration

__all__ = ["REGISTRY", "Exported", "Format", "Writer", "exporter", "format_names"]


@dataclass(frozen=True)
class Exported:
    """What an exporter produced.

    Attributes
    ----------
    text : str
        The file's content.
    notes : list of str
        One line per thing the format cannot express, with the residual it
        leaves (empty when the export is exact).
    """

    text: str
    notes: list = field(default_factory=list)


@dataclass(frozen=True)
class Format:
    """A registered format: its name, file suffixes, one-line help and writer."""

    name: str
    suffixes: tuple
    help: str
    write: Writer


#: An exporter: a calibration in, the file's text and notes out.
Writer = Callable[["Calibration"], Exported]

#: name -> Format, in registration order.
REGISTRY: dict[str, Format] = {}


def exporter(name: str, suffixes: Iterable[str], help: str) -> Callable[[Writer], Writer]:
    """Register ``func(calibration) -> Exported`` as format ``name``.

    Parameters
    ----------
    name : str
        The ``--format`` value.
    suffixes : tuple of str
        Output file name endings that select this format (``".json"``).
    help : str
        One line for ``--help``.
    """

    def register(func: Writer) -> Writer:

        REGISTRY[name] = Format(name, tuple(suffixes), help, func)
        return func

    return register


def format_names() -> tuple[str, ...]:
    """Registered format names, in registration order."""
    return tuple(REGISTRY)
