"""Averaging of tracker readings; the logic lives in :mod:`calibrator.acquire.averaging`.

Kept for the driver's callers: :func:`measure_average` here raises the
driver's :class:`~drivers.tracker.errors.TargetUnstable` when too few readings
were accepted. The domain module is imported on first use, so the tracker
simulator (which imports this package) stays free of the domain.
"""

from __future__ import annotations

from drivers.tracker.errors import TargetUnstable
from drivers.tracker.protocol import ErrorCode

__all__ = ["measure_average"]  # and AveragedReading, on demand (see __getattr__)


def measure_average(tracker, n: int = 10, *, reject_flagged: bool = True, min_count=None):
    """:func:`calibrator.acquire.averaging.measure_average`, with the driver's error type."""
    from calibrator.acquire import averaging

    try:
        return averaging.measure_average(
            tracker, n, reject_flagged=reject_flagged, min_count=min_count
        )
    except averaging.TooFewReadings as exc:
        raise TargetUnstable(
            int(ErrorCode.TARGET_UNSTABLE), ErrorCode.TARGET_UNSTABLE.name, str(exc), "MEAS"
        ) from exc


def __getattr__(name):
    if name == "AveragedReading":
        from calibrator.acquire.averaging import AveragedReading

        return AveragedReading
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
