"""Averaging of tracker readings; the logic lives in :mod:`calibrator.acquire.averaging`.

Kept for the driver's callers: :func:`measure_average` here raises the
driver's :class:`~drivers.tracker.errors.TargetUnstable` when too few readings
were accepted.
"""

from __future__ import annotations

from calibrator.acquire import averaging
from calibrator.acquire.averaging import AveragedReading
from drivers.tracker.errors import TargetUnstable
from drivers.tracker.protocol import ErrorCode

__all__ = ["AveragedReading", "measure_average"]


def measure_average(
    tracker, n: int = 10, *, reject_flagged: bool = True, min_count: int | None = None
) -> AveragedReading:
    """:func:`calibrator.acquire.averaging.measure_average`, with the driver's error type."""
    try:
        return averaging.measure_average(
            tracker, n, reject_flagged=reject_flagged, min_count=min_count
        )
    except averaging.TooFewReadings as exc:
        raise TargetUnstable(
            int(ErrorCode.TARGET_UNSTABLE), ErrorCode.TARGET_UNSTABLE.name, str(exc), "MEAS"
        ) from exc
