"""Device kinds by URL scheme: the one registry style of trackers and robots.

As pyserial's ``serial_for_url`` finds the module that opens a URL by its
scheme (``serial.urlhandler.protocol_<scheme>``), a :class:`Registry` maps
each scheme to the module that opens it. The module is imported only when
its scheme is used (opening a simulated robot never needs the ``ur-rtde``
wheel, a line-protocol tracker never the emScon packages) and builds the
device with its ``open_url(url, options)``::

    from drivers.tracker import TRACKERS
    from drivers.robot import ROBOTS

    TRACKERS.register("emscon", "drivers.tracker.emscon.device", usage="emscon://HOST[:PORT]")
    tracker = TRACKERS.open("emscon://10.0.0.7", OpenOptions())

A handler may also be ``"module:function"`` (another function than
``open_url``) or a callable (a kind added by a test or a plug-in). Every
device comes back unconnected.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Generic, TypeVar

from drivers.errors import DriverError

__all__ = ["Registry", "UnknownKind", "scheme"]

D = TypeVar("D")
O = TypeVar("O")  # noqa: E741  (the options type, as in the handlers' signature)

#: The function a handler module defines.
OPENER = "open_url"


class UnknownKind(DriverError, ValueError):
    """No device kind is registered for a URL's scheme (the message lists those that are)."""


def scheme(url: str, bare_default: str | None = None) -> str:
    """The kind a URL names: the part before ``://``, lower case; or the bare word itself.

    Parameters
    ----------
    url : str
        ``socket://h:1``, ``sim``, ``sim://?noise=off``, ``/dev/ttyUSB0``.
    bare_default : str, optional
        The kind of a URL with no ``://`` that is no registered bare word (trackers:
        a device path is ``serial``); None: the URL itself.
    """
    if "://" in url:
        return url.split("://", 1)[0].lower()
    return url.lower() if bare_default is None else bare_default


@dataclass(frozen=True)
class _Kind(Generic[D, O]):
    handler: str | Callable[[str, O], D]
    usage: str


class Registry(Generic[D, O]):
    """Device kinds of one sort (trackers or robots) by URL scheme.

    Parameters
    ----------
    noun : str
        What the devices are (``"tracker"``), for the refusal of an unknown scheme.
    bare : tuple of str
        Kinds named by a bare word (``sim``); any other URL without ``://`` is
        ``bare_default``.
    bare_default : str, optional
        The kind of any other URL without ``://`` (None: the word itself).
    """

    def __init__(
        self, noun: str, bare: tuple[str, ...] = (), bare_default: str | None = None
    ) -> None:
        self.noun = noun
        self._bare = bare
        self._bare_default = bare_default
        self._kinds: dict[str, _Kind[D, O]] = {}

    def register(
        self, kind: str, handler: str | Callable[[str, O], D], usage: str | None = None
    ) -> None:
        """Add (or replace) the handler of URL scheme ``kind``: one line per new kind.

        Parameters
        ----------
        kind : str
        handler : str or callable
            ``"package.module"`` (its ``open_url``), ``"package.module:function"``,
            or ``handler(url, options)`` itself.
        usage : str, optional
            How a user writes it (``"ur://HOST"``); default ``kind://``.
        """
        kind = kind.lower()
        self._kinds[kind] = _Kind(handler, usage or (kind if kind in self._bare else f"{kind}://"))

    def kinds(self) -> list[str]:
        """The registered schemes, in the order they were first registered."""
        return list(self._kinds)

    def kind_of(self, url: str) -> str:
        """The scheme ``url`` names (a bare word the registry knows, else ``bare_default``)."""
        if "://" not in url and url.lower() in self._bare:
            return url.lower()
        return scheme(url, self._bare_default)

    def open(self, url: str, options: O) -> D:
        """The device ``url`` names, not yet connected.

        Raises
        ------
        UnknownKind
            No kind is registered for the scheme (a ``ValueError``).
        ValueError
            The URL or an option does not suit the kind (raised by its handler).
        """
        entry = self._kinds.get(self.kind_of(url))
        if entry is None:
            known = " or ".join(kind.usage for kind in self._kinds.values())
            raise UnknownKind(f"unknown {self.noun} {url!r}; use {known}")
        return self.handler(entry.handler)(url, options)

    @staticmethod
    def handler(target: str | Callable[[str, O], D]) -> Callable[[str, O], D]:
        """The function a registered handler names (imports its module)."""
        if not isinstance(target, str):
            return target
        module, _, name = target.partition(":")
        opener: Callable[[str, O], D] = getattr(importlib.import_module(module), name or OPENER)
        return opener
