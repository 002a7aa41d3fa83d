"""Filtering native robot programs with a calibration, one module per language.

Controllers that cannot load a calibrated kinematic model still reach the
calibrated accuracy when every target of their programs is replaced by the
target that makes the real arm land on the intended pose: the calibrated
inverse kinematics in the target's own configuration, then the nominal
forward kinematics (:func:`calibrator.compensate.compensate`), in the
target's own tool and base frames. Everything else in the program stays
byte for byte as it was.

A language is a class registered with :func:`language`: it reads a program
(:meth:`Language.scan` yields :class:`Unit` objects, runs of lines holding
zero or more :class:`Target` objects) and knows its orientation notation,
number layouts and configuration data. :mod:`calibrator.filtering.engine`
streams a program through it. The types, the base class and the table live
in :mod:`calibrator.filtering.base`; importing this package imports every
language module, which registers itself.
"""

from __future__ import annotations

from calibrator.filtering.base import (
    FORMATS,
    REGISTRY,
    FilterError,
    Format,
    Job,
    Language,
    Layout,
    Target,
    Unit,
    choose,
    language,
    numbered_frame,
    read_lines,
    split_ending,
    target_tool,
)

__all__ = [
    "FORMATS",
    "FilterError",
    "Format",
    "Job",
    "Language",
    "Layout",
    "REGISTRY",
    "Target",
    "Unit",
    "choose",
    "language",
    "numbered_frame",
    "read_lines",
    "split_ending",
    "target_tool",
]

# Importing the language modules registers them (order = order of --format choices).
from calibrator.filtering import urscript as _urscript  # noqa: E402,F401  isort: skip
from calibrator.filtering import krl as _krl  # noqa: E402,F401  isort: skip
from calibrator.filtering import rapid as _rapid  # noqa: E402,F401  isort: skip
from calibrator.filtering import fanuc as _fanuc  # noqa: E402,F401  isort: skip
from calibrator.filtering import jbi as _jbi  # noqa: E402,F401  isort: skip
