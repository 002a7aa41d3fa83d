"""The one YAML reader: every YAML input of the project goes through :func:`read`.

A YAML file is small text that can still hurt: nesting 1,000 deep makes
PyYAML's recursive composer raise ``RecursionError``; a few lines of nested
aliases (``a: &a [x, x]``, ``b: &b [*a, *a]``, ...) expand to gigabytes the
moment a message prints the value; a key written twice is silently "last
wins". This reader refuses all of those before a document is built, and
reads numbers in the project's strict grammar:

- size: at most ``max_bytes`` of UTF-8 text (default :data:`MAX_BYTES`);
- depth: collections nested at most :data:`MAX_DEPTH` deep;
- aliases: at most :data:`MAX_ALIASES` of them, and the document as expanded
  (every alias counted as the node it stands for) at most
  :data:`MAX_NODES` nodes and :data:`MAX_CHARS` characters of scalars;
- keys: a key written twice in one mapping is refused;
- numbers: decimal only (:data:`calibrator.inputs.grammar.NUMBER`, YAML 1.2 style:
  ``1e-3`` is a number); ``0x1F``, ``0o17``, ``017``, ``1_000``, ``1:30``,
  ``.nan``, ``.inf`` and integers beyond 64 bits are refused, not converted.

Every refusal is one line naming the file and what is wrong, as a
:class:`calibrator.inputs.errors.StrictError` (a
:class:`~calibrator.errors.CalibrationError`; exit code 2 at the CLI)::

    cell.yaml: nested more than 64 deep (line 65)
    cell.yaml: key 'margin_mm' appears more than once (line 7)
    cell.yaml: aliases expand to more than 100000 values

Use::

    from calibrator.inputs import yamlfile

    doc = yamlfile.read("cell.yaml", "a cell file")          # a path
    doc = yamlfile.read("ur10e.yaml", "a robot description", max_bytes=2**20)
    doc = yamlfile.loads(text, "kinematics.yaml")           # text already read

``what`` names the kind of file in errors about the file itself
(``ur10e.yaml: 5000000 bytes is too large for a robot description``); wrap
the :class:`~calibrator.inputs.errors.StrictError` in your own error class if your
package has one (``cellfile`` raises ``CellError(str(exc))``).

Readers then check the document's shape and types themselves (a reader of
lengths checks that ``min_mm`` is a list of three numbers); this module
guarantees only that the document is small, shallow and unambiguous.
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Any

from calibrator.inputs import grammar, messages
from calibrator.inputs.errors import StrictError
from calibrator.inputs.textfile import read_text

__all__ = ["MAX_ALIASES", "MAX_BYTES", "MAX_CHARS", "MAX_DEPTH", "MAX_NODES", "loads", "read"]

#: Largest YAML file read by default (bytes): a cell or description is a few kB.
MAX_BYTES = 4 * 2**20
#: Deepest nesting of collections (a cell file nests 4 deep).
MAX_DEPTH = 64
#: Most aliases (``*name``) in one document.
MAX_ALIASES = 1_000
#: Most nodes of the document with every alias expanded.
MAX_NODES = 1_000_000
#: Most characters of scalars with every alias expanded (as much as a file holds).
MAX_CHARS = MAX_BYTES


def read(
    path: str | os.PathLike[str], what: str = "a YAML file", max_bytes: int = MAX_BYTES
) -> Any:
    """The document of a YAML file, read within the limits of this module.

    Parameters
    ----------
    path : str or Path
    what : str
        The kind of file, for errors about the file itself (``"a cell file"``).
    max_bytes : int
        Largest file taken.

    Returns
    -------
    The document: dicts, lists, str, int, float, bool, None (None for an
    empty file).

    Raises
    ------
    calibrator.inputs.errors.StrictError
        Missing, too large, not UTF-8, not YAML, too deep, too many or too
        large aliases, a duplicate key, a number outside the grammar. One
        line, starting with the path.
    """
    return loads(read_text(Path(path), max_bytes, what), str(path))


def loads(text: str, where: str = "YAML") -> Any:
    """The document of YAML text, parsed within the limits of this module.

    ``where`` (a path) starts every error message. See :func:`read`.
    """
    import yaml  # type: ignore[import-untyped]

    try:
        _check_shape(yaml.parse(text, Loader=_base()))
        return yaml.load(text, Loader=_loader())  # noqa: S506 (a SafeLoader subclass)
    except StrictError as exc:
        raise StrictError(f"{where}: {exc}") from None
    except RecursionError:  # not reached within MAX_DEPTH; kept as a last guard
        raise StrictError(f"{where}: nested too deeply") from None
    except yaml.YAMLError as exc:
        if "increasing flow level" in str(exc) or "increasing block level" in str(exc):
            # libyaml's own nesting limit (1,000), met before the events reach ours.
            raise StrictError(f"{where}: nested more than {MAX_DEPTH} deep") from None
        raise StrictError(f"{where}: not YAML ({_first_line(exc)})") from None


def _first_line(exc: Exception) -> str:
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    mark = getattr(exc, "problem_mark", None)
    text = lines[0] if lines else type(exc).__name__
    if mark is not None and "line" not in text:
        text += f", line {mark.line + 1}"
    return text[:200]


def _check_shape(events: Any) -> None:
    """Refuse deep nesting and alias expansion, from the parser's events (no recursion).

    Each open collection counts its expanded nodes and characters; an alias
    adds the totals of the node its anchor named, so ``b: [*a, *a]`` counts
    ``a`` twice, as printing it would.
    """
    import yaml

    stack: list[list[int]] = []  # [nodes, chars] of each open collection
    anchors: dict[str, tuple[int, int]] = {}
    opened_anchor: list[str | None] = []
    total = [0, 0]
    aliases = 0

    def add(nodes: int, chars: int, line: int) -> None:
        target = stack[-1] if stack else total
        target[0] += nodes
        target[1] += chars
        if target[0] > MAX_NODES:
            raise StrictError(f"aliases expand to more than {MAX_NODES} values (line {line})")
        if target[1] > MAX_CHARS:
            raise StrictError(f"aliases expand to more than {MAX_CHARS} characters (line {line})")

    for event in events:
        line = event.start_mark.line + 1
        if isinstance(event, yaml.CollectionStartEvent):
            if len(stack) >= MAX_DEPTH:
                raise StrictError(f"nested more than {MAX_DEPTH} deep (line {line})")
            stack.append([1, 0])
            opened_anchor.append(event.anchor)
        elif isinstance(event, yaml.CollectionEndEvent):
            nodes, chars = stack.pop()
            anchor = opened_anchor.pop()
            if anchor is not None:
                anchors[anchor] = (nodes, chars)
            add(nodes, chars, line)
        elif isinstance(event, yaml.ScalarEvent):
            if event.anchor is not None:
                anchors[event.anchor] = (1, len(event.value))
            add(1, len(event.value), line)
        elif isinstance(event, yaml.AliasEvent):
            aliases += 1
            if aliases > MAX_ALIASES:
                raise StrictError(f"more than {MAX_ALIASES} aliases (line {line})")
            if event.anchor not in anchors:  # an alias of an open collection: a cycle
                raise StrictError(f"alias *{event.anchor} refers to itself (line {line})")
            add(*anchors[event.anchor], line)


_LOADER = None
_INTEGER = re.compile(r"[+-]?[0-9]+")


def _base() -> Any:
    """libyaml's safe loader where PyYAML has it (5 times faster), else the Python one."""
    import yaml

    return getattr(yaml, "CSafeLoader", yaml.SafeLoader)


def _loader() -> Any:
    """A SafeLoader subclass with the strict grammar and unique keys, built once."""
    global _LOADER
    if _LOADER is not None:
        return _LOADER
    import yaml

    class StrictLoader(_base()):  # type: ignore[misc]
        pass

    # Own copy of the resolver table: add_implicit_resolver would append to
    # lists shared with SafeLoader.
    StrictLoader.yaml_implicit_resolvers = {
        ch: list(v) for ch, v in yaml.SafeLoader.yaml_implicit_resolvers.items()
    }
    StrictLoader.add_implicit_resolver(
        "tag:yaml.org,2002:float", grammar.NUMBER, list("-+0123456789.")
    )

    def mapping(loader: Any, node: Any, deep: bool = False) -> Any:
        seen = set()
        for key_node, _ in node.value:
            if key_node.tag == "tag:yaml.org,2002:merge":
                continue  # "<<: *base": its keys may be overridden here, as YAML says
            key = loader.construct_object(key_node, deep=True)
            try:
                duplicate = key in seen
            except TypeError:
                continue  # an unhashable key: SafeLoader refuses it itself
            if duplicate:
                raise StrictError(
                    f"key {messages.short(key)} appears more than once "
                    f"(line {key_node.start_mark.line + 1})"
                )
            seen.add(key)
        return yaml.SafeLoader.construct_mapping(loader, node, deep=deep)

    def integer(loader: Any, node: Any) -> int:
        s = loader.construct_scalar(node).strip()
        line = node.start_mark.line + 1
        # "017" is octal in YAML 1.1 and decimal in 1.2: ambiguous, so refused.
        if not _INTEGER.fullmatch(s) or re.fullmatch(r"[+-]?0[0-9]+", s):
            raise StrictError(f"{messages.short(s)} (line {line}) is not a decimal number")
        if len(s.lstrip("+-")) > 19 or abs(int(s)) > grammar.MAX_INT:
            raise StrictError(f"line {line}: the integer {messages.short(s)} is beyond 64 bits")
        return int(s)

    def real(loader: Any, node: Any) -> float:
        return grammar.parse_number(
            loader.construct_scalar(node), f"line {node.start_mark.line + 1}"
        )

    StrictLoader.construct_mapping = mapping  # type: ignore[method-assign,assignment]
    StrictLoader.add_constructor("tag:yaml.org,2002:int", integer)
    StrictLoader.add_constructor("tag:yaml.org,2002:float", real)
    _LOADER = StrictLoader
    return _LOADER
