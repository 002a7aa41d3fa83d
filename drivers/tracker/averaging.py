"""Averaging of tracker readings; the logic lives in :mod:`calibrator.acquire.averaging`.

Kept for the driver's callers: :func:`measure_average` here raises the
driver's :class:`~drivers.tracker.errors.TargetUnstable` when the set is
rejected (too few readings accepted, or a spread above the limit). The domain
module is imported on first use, so the tracker simulator (which imports this
package) stays free of the domain.
"""

from __future__ import annotations

from typing import Any

from drivers.tracker.errors import TargetUnstable
from drivers.tracker.line.protocol import ErrorCode

__all__ = ["measure_average"]  # and AveragedReading, on demand (see __getattr__)


def measure_average(tracker: Any, n: int = 10, **options: Any) -> Any:
    """:func:`calibrator.acquire.averaging.measure_average`, with the driver's error type.

    ``options`` are that function's keywords (``reject_flagged``, ``min_count``,
    ``accuracy``, ``max_spread_mm``).
    """
    from calibrator.acquire import averaging

    try:
        return averaging.measure_average(tracker, n, **options)
    except averaging.SetRejected as exc:
        raise TargetUnstable(
            int(ErrorCode.TARGET_UNSTABLE), ErrorCode.TARGET_UNSTABLE.name, str(exc), "MEAS"
        ) from exc


def __getattr__(name: str) -> Any:
    if name == "AveragedReading":
        from calibrator.acquire.averaging import AveragedReading

        return AveragedReading
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
