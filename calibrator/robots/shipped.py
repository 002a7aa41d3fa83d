"""Arms described as data: every ``data/*.yaml`` description file shipped here.

Each file (format ``calibrator-robot/1``, :mod:`calibrator.robots.files`)
names the source of every number; the URDFs beside them are written from
the manufacturers' data as ROS-Industrial's support packages give them.
"""

from __future__ import annotations

import functools
from pathlib import Path

from calibrator.robots import files
from calibrator.robots.description import RobotDescription

#: Where the shipped description files are.
DATA = Path(__file__).with_name("data")


def _builder(path: Path):
    return functools.partial(files.load, path)


def _shipped() -> dict[str, functools.partial[RobotDescription]]:
    return {p.stem: _builder(p) for p in sorted(DATA.glob("*.yaml"))}


#: The arms of this module, by name (the file's stem; the file's ``name`` must match).
DESCRIPTIONS = _shipped()
