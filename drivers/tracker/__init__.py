"""Laser-tracker support: protocol, driver on pyserial, averaging, recording, simulator.

The measure loop needs::

    from drivers.tracker import LaserTracker, Environment, measure_average

    with LaserTracker("socket://127.0.0.1:5000", record="raw.jsonl") as tracker:
        identity, status = tracker.connect(Environment(20.0, 1013.25, 45.0))
        if not status.initialised:
            tracker.initialise()
        avg = measure_average(tracker, n=10)   # avg.mean_mm, avg.std_mm, avg.count

The simulator lives in :mod:`drivers.tracker.simulator` (imported on demand).
"""

from drivers.tracker.averaging import measure_average
from drivers.tracker.driver import Environment, Identity, LaserTracker, Status
from drivers.tracker.errors import (
    BeamBroken,
    ChecksumError,
    ConnectionLost,
    FrameError,
    FrameRejected,
    IdentityChanged,
    NotInitialised,
    TargetUnstable,
    TrackerBusy,
    TrackerError,
    TrackerTimeout,
)
from drivers.tracker.protocol import Reading, ReadingStatus
from drivers.tracker.recording import Recorder, read_log

__all__ = [
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
    "NotInitialised",
    "Reading",
    "ReadingStatus",
    "Recorder",
    "Status",
    "TargetUnstable",
    "TrackerBusy",
    "TrackerError",
    "TrackerTimeout",
    "measure_average",
    "read_log",
]


def __getattr__(name):
    # AveragedReading lives in calibrator.acquire; imported on demand (see averaging.py).
    if name == "AveragedReading":
        from drivers.tracker import averaging

        return averaging.AveragedReading
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
