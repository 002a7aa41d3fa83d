"""Robot descriptions: one :class:`RobotDescription` per arm, the one home of its data.

Every module of this package that defines ``DESCRIPTIONS`` (a mapping of
lower-case arm names to functions building a :class:`RobotDescription`) adds
its arms: adding an arm is one new module here and nothing else. The shipped
modules are one per family: :mod:`~calibrator.robots.ur` (Universal Robots),
:mod:`~calibrator.robots.ipso_paper` (the IPSO paper's ER10L-C10). The
source papers' analysis arms, which are not 6R calibration targets, keep
their data in :mod:`~calibrator.robots.misalignment_paper` and
:mod:`~calibrator.robots.deflection_paper`.

Use :func:`get` to look an arm up by name (or a description file by path).
"""

from __future__ import annotations

import dataclasses
import functools
import importlib
import pkgutil
from collections.abc import Callable
from pathlib import Path

from calibrator.robots import files
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
    "convention_of",
    "files",
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


def convention_of(name: str | None) -> JointConvention:
    """The controller convention of the arm ``name``; identity for None or an arm not found.

    An arm only a table describes (a session's ``nominal_mdh``) has no
    controller of its own to speak of: its angles are the table's.
    """
    if not name:
        return JointConvention()
    try:
        return get(name).convention
    except DescriptionError:
        return JointConvention()


def names() -> tuple[str, ...]:
    """Names of the described arms, sorted."""
    return tuple(sorted(_builders()))


#: Endings of description files :func:`get` reads instead of looking a name up.
FILE_SUFFIXES = (".yaml", ".yml", ".urdf")


def is_file_name(name: str) -> bool:
    """Whether ``name`` names a description file (a path ending in .yaml, .yml or .urdf)."""
    return str(name).split("#", 1)[0].strip().lower().endswith(FILE_SUFFIXES)


def get(
    name: str, *, base_link: str | None = None, tip_link: str | None = None
) -> RobotDescription:
    """The description of the arm called ``name`` (case-insensitive), or in a file.

    Parameters
    ----------
    name : str
        A shipped arm's name (:func:`names`), or the path of a description
        file (``arm.yaml``) or URDF (``arm.urdf``; ``arm.urdf#base:tip`` names
        the chain's links, as the description's own name records them).
    base_link, tip_link : str, optional
        For a URDF: the chain's first and last links [default: ``base_link``;
        ``tool0``, else ``flange``].

    Returns
    -------
    RobotDescription
        Named ``name`` (for a file: the path as given, with ``#base:tip``
        when the links were given), so that ``get(d.name)`` gives ``d`` again.

    Raises
    ------
    DescriptionError
        An unknown name (the message lists the known ones), or a file that
        cannot be read or describes an arm that is not supported.
    """
    if is_file_name(name):
        return _from_file(str(name).strip(), base_link, tip_link)
    if base_link is not None or tip_link is not None:
        raise DescriptionError(f"--base-link and --tip-link are for a URDF, not {name!r}")
    key = str(name).strip().lower()
    builders = _builders()
    if key not in builders:
        raise DescriptionError(f"unknown model {name!r}; known: {', '.join(sorted(builders))}")
    # Built once per process (a shipped file is parsed once); each caller gets
    # its own copy of the arrays, as a fresh build would give.
    return dataclasses.replace(_built(tuple(__path__), key))


@functools.lru_cache(maxsize=64)
def _built(path: tuple[str, ...], key: str) -> RobotDescription:
    description = _scan(path)[key]()
    if description.name != key:
        raise DescriptionError(f"robot module for {key!r} built {description.name!r}")
    return description


def _from_file(name: str, base_link: str | None, tip_link: str | None) -> RobotDescription:
    path, _, links = name.partition("#")
    try:
        stat = Path(path).stat()
    except OSError:
        stat = None
    if stat is None:
        return _read_file(name, base_link, tip_link)
    # A file is read again only when it changed (commands look an arm up several times).
    key = (name, base_link, tip_link, str(Path(path).resolve()), stat.st_mtime_ns, stat.st_size)
    return dataclasses.replace(_read_file_once(*key))


@functools.lru_cache(maxsize=16)
def _read_file_once(
    name: str, base_link: str | None, tip_link: str | None, *_stamp: object
) -> RobotDescription:
    return _read_file(name, base_link, tip_link)


def _read_file(name: str, base_link: str | None, tip_link: str | None) -> RobotDescription:
    from calibrator import outputs
    from calibrator.robots import urdf

    path, _, links = name.partition("#")
    outputs.note_input(path)  # an input of the command: no output may replace it
    if links:
        if base_link is not None or tip_link is not None:
            raise DescriptionError(f"{name}: give the links once, in the name or as options")
        base_link, _, tip_link = links.partition(":")
        base_link, tip_link = base_link or None, tip_link or None
    if path.lower().endswith(".urdf"):
        recorded = path
        if base_link is not None or tip_link is not None:
            recorded = f"{path}#{base_link or ''}:{tip_link or ''}"
        return urdf.describe(path, base_link, tip_link, name=recorded)
    if base_link is not None or tip_link is not None:
        raise DescriptionError(f"{path}: --base-link and --tip-link are for a URDF")
    return files.load(path, name=path)
