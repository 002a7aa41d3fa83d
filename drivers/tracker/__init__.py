"""Laser-tracker support: one opener by URL, protocol, driver on pyserial, averaging, simulator.

Any tracker kind is opened by URL (:func:`open_tracker`, registry in
:mod:`drivers.tracker.base`) and satisfies the measure loop's port directly::

    # requires hardware
    from drivers.tracker import open_tracker, measure_average

    tracker = open_tracker("socket://127.0.0.1:5000")
    status = tracker.connect()
    if not status.initialised:
        tracker.initialise()
    avg = measure_average(tracker, n=10)   # avg.mean_mm, avg.std_mm, avg.count
    tracker.close()

The simulated tracker is :mod:`drivers.tracker.instrument`, served in the line protocol by
:mod:`drivers.tracker.line.simulator` and behind emScon by
:mod:`drivers.tracker.emscon.simulator` (imported on demand).
"""

from drivers.registry import UnknownKind
from drivers.tracker.averaging import measure_average
from drivers.tracker.base import (
    TRACKERS,
    Environment,
    OpenOptions,
    open_tracker,
    register_tracker,
)
from drivers.tracker.errors import (
    BeamBroken,
    ChecksumError,
    ConnectionLost,
    FrameError,
    FrameRejected,
    IdentityChanged,
    LinkDropped,
    NotInitialised,
    TargetUnstable,
    TrackerBusy,
    TrackerError,
    TrackerGone,
    TrackerTimeout,
)
from drivers.tracker.line.device import Identity, LaserTracker, Status
from drivers.tracker.line.protocol import Reading, ReadingStatus
from drivers.tracker.recording import Recorder, read_log

__all__ = [
    "TRACKERS",
    "AveragedReading",
    "BeamBroken",
    "ChecksumError",
    "ConnectionLost",
    "Environment",
    "FrameError",
    "FrameRejected",
    "Identity",
    "IdentityChanged",
    "LaserTracker",
    "LinkDropped",
    "OpenOptions",
    "NotInitialised",
    "Reading",
    "ReadingStatus",
    "Recorder",
    "Status",
    "TargetUnstable",
    "TrackerBusy",
    "TrackerError",
    "TrackerGone",
    "TrackerTimeout",
    "UnknownKind",
    "measure_average",
    "open_tracker",
    "read_log",
    "register_tracker",
]


def __getattr__(name):
    # AveragedReading lives in calibrator.acquire; imported on demand (see averaging.py).
    if name == "AveragedReading":
        from drivers.tracker import averaging

        return averaging.AveragedReading
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
