"""Robot descriptions: one :class:`RobotDescription` per arm, the one home of its data.

Every module of this package that defines ``DESCRIPTIONS`` (a mapping of
lower-case arm names to functions building a :class:`RobotDescription`) adds
its arms: adding an arm is one new module here and nothing else. The shipped
modules are one per family: :mod:`~calibrator.robots.ur` (Universal Robots),
:mod:`~calibrator.robots.ipso_paper` (the IPSO paper's ER10L-C10). The
source papers' analysis arms, which are not 6R calibration targets, keep
their data in :mod:`~calibrator.robots.misalignment_paper` and
:mod:`~calibrator.robots.deflection_paper`.

Use :func:`get` (or :func:`calibrator.models.get_model`, the same) to look an
arm up by name.
"""

from __future__ import annotations

import functools
import importlib
import pkgutil
from collections.abc import Callable

from calibrator.robots.description import (
    FORMAT,
    Body,
    Capsule,
    DescriptionError,
    JointConvention,
    RobotDescription,
)

__all__ = [
    "FORMAT",
    "Body",
    "Capsule",
    "DescriptionError",
    "JointConvention",
    "RobotDescription",
    "get",
    "names",
]

Builder = Callable[[], RobotDescription]


def _builders() -> dict[str, Builder]:
    """Every ``DESCRIPTIONS`` entry of the package's modules, by name."""
    return _scan(tuple(__path__))


@functools.lru_cache(maxsize=4)
def _scan(path: tuple[str, ...]) -> dict[str, Builder]:
    found: dict[str, Builder] = {}
    for info in sorted(pkgutil.iter_modules(list(path)), key=lambda m: m.name):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{__name__}.{info.name}")
        for name, build in getattr(module, "DESCRIPTIONS", {}).items():
            key = name.lower()
            if key in found:
                raise DescriptionError(f"robot {key!r} is described twice ({info.name})")
            found[key] = build
    return found


def names() -> tuple[str, ...]:
    """Names of the described arms, sorted."""
    return tuple(sorted(_builders()))


def get(name: str) -> RobotDescription:
    """The description of the arm called ``name`` (case-insensitive).

    Raises
    ------
    DescriptionError
        If no arm has that name (the message lists the known ones).
    """
    key = str(name).strip().lower()
    builders = _builders()
    if key not in builders:
        raise DescriptionError(f"unknown model {name!r}; known: {', '.join(sorted(builders))}")
    description = builders[key]()
    if description.name != key:
        raise DescriptionError(f"robot module for {key!r} built {description.name!r}")
    return description
