"""Leica emScon over TCP: packet layouts, the adapter behind the ``Tracker`` port, a simulator.

See ``docs/leica-emscon.md``. ``open_tracker("emscon://HOST[:PORT]")`` builds the adapter.
"""

from drivers.tracker.emscon.device import (
    DEFAULT_PORT,
    EmsconReading,
    EmsconStatus,
    EmsconTracker,
    open_tracker,
)

__all__ = ["DEFAULT_PORT", "EmsconReading", "EmsconStatus", "EmsconTracker", "open_tracker"]
