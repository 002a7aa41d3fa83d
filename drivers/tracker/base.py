"""What every tracker driver shares: meteo data, open options, and the URL registry.

A tracker kind is one package plus one line in the registry
(:data:`TRACKERS`, a :class:`drivers.registry.Registry`): the module whose
``open_url(url, options) -> Tracker`` builds an unconnected object which
already satisfies :class:`calibrator.acquire.ports.Tracker` (raises the
port's errors itself and declares its ``capabilities``). As pyserial's
``serial_for_url`` picks a transport by URL scheme, :func:`open_tracker`
picks the driver::

    from drivers.tracker import open_tracker

    tracker = open_tracker("socket://127.0.0.1:5000")   # the line protocol
    tracker = open_tracker("emscon://10.0.0.7")         # a Leica emScon server

Handlers are imported only when their scheme is used, so opening a
line-protocol tracker never imports the emScon packages.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from drivers.registry import Registry

if TYPE_CHECKING:
    from calibrator.acquire.ports import Tracker
    from calibrator.simulate import SimWorld


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
        The simulated world (the ``sim`` kind only; it needs one). The simulator's
        own settings (noise, probe, faults, replay) are in its URL
        (``sim://?noise=off&probe=6dof``), as pyserial configures ``loop://``.
    """

    record: str | Path | None = None
    world: SimWorld | None = None


#: Tracker kinds by URL scheme (:mod:`drivers.registry`): each module opens its
#: URLs with ``open_url(url, options)``. pyserial's URL schemes and bare device
#: paths go to the line-protocol driver.
TRACKERS: Registry[Tracker, OpenOptions] = Registry(
    "tracker", bare=("sim", "emscon+sim"), bare_default="serial"
)
_LINE = "drivers.tracker.line.device"
TRACKERS.register("sim", "drivers.tracker.line.simulator.world")
TRACKERS.register("serial", _LINE, usage="a device path")
TRACKERS.register("socket", _LINE, usage="socket://HOST:PORT")
TRACKERS.register("rfc2217", _LINE, usage="rfc2217://HOST:PORT")
TRACKERS.register("loop", _LINE)
TRACKERS.register("emscon", "drivers.tracker.emscon.device", usage="emscon://HOST[:PORT]")
# The simulated cell with a Leica tracker: the emScon simulator behind the emScon driver.
TRACKERS.register("emscon+sim", "drivers.tracker.emscon.simulator.world")


def register_tracker(
    kind: str, handler: str | Callable[[str, OpenOptions], Tracker], usage: str | None = None
) -> None:
    """Add (or replace) the handler of URL scheme ``kind``: one line per new tracker kind.

    ``handler`` is a module name (its ``open_url(url, options)`` opens the URL),
    ``"module:function"``, or the function itself (see :class:`drivers.registry.Registry`).
    """
    TRACKERS.register(kind, handler, usage)


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
    drivers.registry.UnknownKind
        No kind is registered for the scheme (the message lists those that are).
    ValueError
        The URL or an option does not suit the kind.
    """
    return TRACKERS.open(url, options or OpenOptions())
