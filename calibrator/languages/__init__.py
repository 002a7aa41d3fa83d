"""Robot languages: one package per language holding its writer and its reader.

- ``calibrator.languages.<language>.writer``: the plan as a program in that
  language (``calibrator program``), registered with
  :func:`calibrator.languages.registry.writer`; the shared writing parts are
  :mod:`~calibrator.languages.spec`, :mod:`~calibrator.languages.names`,
  :mod:`~calibrator.languages.statements` and the entry points
  :mod:`~calibrator.languages.writing`; :mod:`~calibrator.languages.table` is
  the language-free CSV table of the moves.
- ``calibrator.languages.<language>.reader``: the :class:`Language` that reads
  a program's targets for the filter (``calibrator compensate PROGRAM``,
  :mod:`calibrator.compensate.programs`), registered with
  :func:`calibrator.languages.reading.language`; the shared reading parts are
  :mod:`~calibrator.languages.reading` (job, units, targets, the table),
  :mod:`~calibrator.languages.lexing`, :mod:`~calibrator.languages.numbers`,
  :mod:`~calibrator.languages.configuration`,
  :mod:`~calibrator.languages.convention` and
  :mod:`~calibrator.languages.frames_file`.

Importing this package imports every language, so the one table of languages
(:data:`calibrator.languages.registry.LANGUAGES`) is full.

Why read programs: controllers that cannot load a calibrated kinematic model still reach the
calibrated accuracy when every target of their programs is replaced by the
target that makes the real arm land on the intended pose: the calibrated
inverse kinematics in the target's own configuration, then the nominal
forward kinematics (:func:`calibrator.compensate.compensate`), in the
target's own tool and base frames. Everything else in the program stays
byte for byte as it was.

A reader is a class registered with
:func:`~calibrator.languages.reading.language`: it reads a program (``scan``
yields units, runs of lines holding zero or more targets) and knows its
orientation notation, number layouts and configuration data.
:mod:`calibrator.compensate.programs` streams a program through it.
"""

from __future__ import annotations

# Importing the language packages registers them (order = order of --format choices).
from calibrator.languages import urscript as _urscript  # noqa: E402,F401  isort: skip
from calibrator.languages import krl as _krl  # noqa: E402,F401  isort: skip
from calibrator.languages import rapid as _rapid  # noqa: E402,F401  isort: skip
from calibrator.languages import fanuc as _fanuc  # noqa: E402,F401  isort: skip
from calibrator.languages import table as _table  # noqa: E402,F401  isort: skip
from calibrator.languages import jbi as _jbi  # noqa: E402,F401  isort: skip
