"""The tracker's clock, as the watching reads it: the readings' own time stamps.

A stop is timed by when its readings were taken, not by when they reached
the host: a reading a busy host picks up late still carries its time, so the
settle window measures the arm rather than the host's scheduler. Between
readings (a lost beam, the pause between two polls) the clock runs on at the
rate measured between the tracker's stamps and the host's clock, and the
pause between polls lasts that many tracker seconds. A tracker whose stamps
stand still or run back is timed by the host.

So the watching runs at the tracker's pace. A simulated tracker run faster
than real time (``python -m drivers.tracker.line.simulator --time-scale X``, the
external-robot simulator at the same scale) makes the settle window, the
stop timeout and the polling X times shorter on the wall clock, every
decision taken as in real time.

Units: s.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

#: Host seconds over which the tracker's rate is first measured: over shorter spans
#: when a reading reaches the host says more than the stamps do.
RATE_SPAN_S = 0.05
#: Bounds of the measured rate, tracker s per host s: no tracker's clock is further off,
#: and no odd stamp may stall or race the watching.
RATE_BOUNDS = (0.01, 100.0)


class TrackerClock:
    """Tracker seconds since the watching started, from the readings' stamps.

    Parameters
    ----------
    host : callable
        The host's monotonic clock, s (replaceable in tests).

    Attributes
    ----------
    rate : float
        Tracker seconds per host second, measured (1 until it is).
    """

    def __init__(self, host: Callable[[], float] = time.monotonic) -> None:
        self._host = host
        self._anchor = (0.0, host())  # (tracker s, host s) of the latest stamp that advanced
        self._offset: float | None = None  # stamp minus tracker time, s
        self._first: tuple[float, float] | None = None  # where the rate is measured from
        self.rate = 1.0

    def now(self) -> float:
        """Tracker time now, s: the latest stamp, run on at :attr:`rate` since it came."""
        t, host = self._anchor
        return t + (self._host() - host) * self.rate

    def stamp(self, device_time_us: float) -> float:
        """The tracker time of a reading stamped ``device_time_us`` (us), s."""
        host = self._host()
        if self._offset is None:  # the first stamp: tracker time goes on from the host's count
            self._offset = float(device_time_us) * 1e-6 - self.now()
        t = float(device_time_us) * 1e-6 - self._offset
        last, last_host = self._anchor
        if not t > last:  # a stamp standing still or running back: the host times it
            return last + (host - last_host) * self.rate
        if self._first is None:
            self._first = (t, host)
        elif host - self._first[1] >= RATE_SPAN_S:
            rate = (t - self._first[0]) / (host - self._first[1])
            self.rate = float(np.clip(rate, *RATE_BOUNDS))
        self._anchor = (t, host)
        return t

    def host_seconds(self, seconds: float) -> float:
        """How long ``seconds`` of tracker time last on the host's clock, s."""
        return seconds / self.rate
