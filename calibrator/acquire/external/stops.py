"""Stop detection: when does a stream of tracker readings say the arm stands still?

A stop is taken when the readings of the last ``window_s`` seconds stay
within ``band_mm``: their straight-line drift over the window (least-squares
velocity times the window) and their RMS distance about their mean are both
at most the band. Testing drift and RMS, not each reading's distance, keeps
the tracker's own noise (about 25 um RMS at 3 m on the simulator's ISO 10360
model) from vetoing a stop while a creeping arm (drift) or one still ringing
(RMS) is never taken as stopped. After a stop the detector is disarmed until
the target has moved away (farther than :data:`REARM_FACTOR` bands from the
stop) or the beam was lost, so one dwell gives one stop however long it is.
Readings lost while the arm moves (beam broken, target out of reach) only
restart the window: they are expected, never a failure.

Units: s and mm, tracker frame.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

#: The target must leave the stop by this many bands before a new stop counts
#: (noise is a small fraction of the band, so noise alone never re-arms).
REARM_FACTOR = 10.0


@dataclass(frozen=True)
class StopOptions:
    """How a stop is recognised and matched to the plan.

    Attributes
    ----------
    band_mm : float
        Stationarity band: largest drift over the window and largest RMS
        distance of the window's readings about their mean, mm.
    window_s : float
        Settle window: how long the readings must stay in the band, s.
    tolerance_mm : float
        Association tolerance: largest distance between a stop and where a
        plan pose is expected (or between stop-to-stop and pose-to-pose
        distances before the registration exists), mm.
    timeout_s : float
        With no stop for this long the program is taken as ended or stopped:
        the poses still awaited are reported missing, s.
    poll_s : float
        Interval between tracker readings while watching, s.
    """

    band_mm: float = 0.05
    window_s: float = 0.5
    tolerance_mm: float = 15.0
    timeout_s: float = 30.0
    poll_s: float = 0.02

    def __post_init__(self) -> None:
        for name in ("band_mm", "window_s", "tolerance_mm", "timeout_s"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number, got {value!r}")
        if not (np.isfinite(self.poll_s) and self.poll_s >= 0):
            raise ValueError(f"poll_s must be >= 0, got {self.poll_s!r}")


@dataclass(frozen=True)
class Stop:
    """One detected stop.

    Attributes
    ----------
    number : int
        Order of the stop in the run (0-based).
    time_s : float
        Clock at the end of the settle window, s.
    point_mm : numpy.ndarray, shape (3,)
        Mean of the stop's readings, tracker frame, mm.
    readings : tuple
        The tracker readings taken at the stop (what the pose records).
    """

    number: int
    time_s: float
    point_mm: np.ndarray
    readings: tuple = ()


class StopDetector:
    """Feed readings in time order; :meth:`add` says when the window is stationary.

    Parameters
    ----------
    band_mm, window_s : float
        See :class:`StopOptions`.
    """

    def __init__(self, band_mm: float, window_s: float):
        self.band_mm = float(band_mm)
        self.window_s = float(window_s)
        self._window: deque[tuple[float, np.ndarray]] = deque()
        self._last_stop: np.ndarray | None = None

    def lost(self) -> None:
        """A reading was lost (beam broken while moving): restart the window and re-arm."""
        self._window.clear()
        self._last_stop = None

    def add(self, time_s: float, point_mm: ArrayLike) -> np.ndarray | None:
        """Add one reading; return the window's mean (shape (3,), mm) when a stop is taken."""
        point = np.asarray(point_mm, dtype=float).reshape(3)
        if self._last_stop is not None:
            if np.linalg.norm(point - self._last_stop) <= REARM_FACTOR * self.band_mm:
                return None  # still at (or vibrating about) the last stop
            self._last_stop = None
        self._window.append((time_s, point))
        # Keep the newest readings spanning at least the window (one older reading included).
        while len(self._window) > 2 and self._window[1][0] <= time_s - self.window_s:
            self._window.popleft()
        if time_s - self._window[0][0] < self.window_s:
            return None
        times = np.array([t for t, _ in self._window])
        points = np.array([p for _, p in self._window])
        mean = points.mean(axis=0)
        dt = times - times.mean()
        velocity = dt @ (points - mean) / max(float(dt @ dt), 1e-12)  # mm/s, least squares
        drift = np.linalg.norm(velocity) * (times[-1] - times[0])
        rms = np.sqrt(np.mean(np.sum((points - mean) ** 2, axis=1)))
        if drift > self.band_mm or rms > self.band_mm:
            return None
        self._window.clear()
        self._last_stop = mean
        return mean

    def left(self, points_mm: ArrayLike, centre_mm: ArrayLike) -> bool:
        """True when readings (shape (M, 3), mm) show the arm left ``centre_mm`` (shape (3,)).

        The same two tests as a stop: the readings' mean moved by more than
        the band, or their RMS about it exceeds the band.
        """
        points = np.asarray(points_mm, dtype=float).reshape(-1, 3)
        mean = points.mean(axis=0)
        rms = np.sqrt(np.mean(np.sum((points - mean) ** 2, axis=1)))
        return bool(np.linalg.norm(mean - centre_mm) > self.band_mm or rms > self.band_mm)
