"""What every tracker driver shares: meteo data, open options, and the URL registry.

A tracker kind is one package plus one entry in the registry: a function
``opener(url, options) -> Tracker`` that builds an unconnected object which
already satisfies :class:`calibrator.acquire.ports.Tracker` (raises the
port's errors itself and declares its ``capabilities``). As pyserial's
``serial_for_url`` picks a transport by URL scheme, :func:`open_tracker`
picks the driver::

    from drivers.tracker import open_tracker

    tracker = open_tracker("socket://127.0.0.1:5000")   # the line protocol
    tracker = open_tracker("emscon://10.0.0.7")         # a Leica emScon server

Openers are imported only when their scheme is used, so opening a
line-protocol tracker never imports the emScon packages.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from calibrator.acquire.ports import Tracker


@dataclass(frozen=True)
class Environment:
    """Meteo data the tracker needs for its refractive index correction."""

    temperature_c: float = 20.0
    pressure_hpa: float = 1013.25
    humidity_pct: float = 50.0


@dataclass(frozen=True)
class OpenOptions:
    """What a caller may ask of any tracker kind when opening it.

    Attributes
    ----------
    record : str or Path, optional
        Log every raw exchange there (kinds that can; others refuse it).
    world : calibrator.simulate.SimWorld, optional
        The simulated world (the ``sim`` kind only; it needs one).
    sim_noise : bool
        The ``sim`` kind's readings carry the tracker's noise (False: exact).
    sim_faults, sim_replay : str or Path, optional
        The ``sim`` kind's fault script, or a recorded exchange it answers from.
    sim_probe_6dof : bool
        The ``sim`` kind's probe reports its orientation too (a 6-DoF probe).
    """

    record: str | Path | None = None
    world: Any = None
    sim_noise: bool = True
    sim_faults: str | Path | None = None
    sim_replay: str | Path | None = None
    sim_probe_6dof: bool = False


Opener = Callable[[str, OpenOptions], "Tracker"]

_LINE = "drivers.tracker.driver:open_line_tracker"
#: Tracker kinds by URL scheme: an opener, or ``"module:function"`` imported on first use.
#: pyserial's URL schemes and bare device paths go to the line-protocol driver.
TRACKER_KINDS: dict[str, Opener | str] = {
    "sim": "drivers.tracker.simulator.world:open_simulated_tracker",
    "serial": _LINE,
    "socket": _LINE,
    "rfc2217": _LINE,
    "loop": _LINE,
    "emscon": "drivers.tracker.emscon.adapter:open_emscon_tracker",
}


class UnknownKind(ValueError):
    """No tracker (or robot) kind is registered for a URL's scheme."""


def scheme(url: str) -> str:
    """``sim``, ``socket``, ``emscon``, ...: the part before ``://`` (a bare path is ``serial``)."""
    if url == "sim":
        return "sim"
    if "://" in url:
        return url.split("://", 1)[0].lower()
    return "serial"


def register_tracker(kind: str, opener: Opener | str) -> None:
    """Add (or replace) the opener of URL scheme ``kind``: one line per new tracker kind."""
    TRACKER_KINDS[kind.lower()] = opener


def open_tracker(url: str, options: OpenOptions | None = None) -> Tracker:
    """The tracker named by ``url``, not yet connected.

    Parameters
    ----------
    url : str
        ``sim``, a device path, a pyserial URL (``socket://``, ``rfc2217://``,
        ``loop://``) or ``emscon://HOST[:PORT]``; any scheme added with
        :func:`register_tracker`.
    options : OpenOptions, optional

    Returns
    -------
    calibrator.acquire.ports.Tracker

    Raises
    ------
    UnknownKind
        No kind is registered for the scheme (the message lists those that are).
    ValueError
        The URL or an option does not suit the kind.
    """
    kind = scheme(url)
    opener = TRACKER_KINDS.get(kind)
    if opener is None:
        raise UnknownKind(
            f"unknown tracker {url!r}; use sim, a device path or one of "
            + ", ".join(f"{k}://" for k in TRACKER_KINDS if k not in ("sim", "serial"))
        )
    if isinstance(opener, str):
        opener = resolve(opener)
    return opener(url, options or OpenOptions())


def resolve(target: str) -> Callable[..., Any]:
    """The function named ``"package.module:function"``."""
    module, _, name = target.partition(":")
    return getattr(importlib.import_module(module), name)
