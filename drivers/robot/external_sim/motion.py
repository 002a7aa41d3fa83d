"""What a controller does with a joint-move program: synchronous trapezoidal moves, dwells.

Plain functions of time, so the player and its tests share them. Units: rad,
rad/s, rad/s^2, s, mm.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from calibrator.languages.spec import trapezoid_duration_s


def trapezoid_duration(distance: float, speed: float, accel: float) -> float:
    """Duration of a rest-to-rest trapezoidal move, s (the program writers' own timing)."""
    return trapezoid_duration_s(distance, speed, accel)


def trapezoid_fraction(
    t: ArrayLike, duration: float, speed: float, accel: float, distance: float
) -> np.ndarray:
    """Fraction (0..1) of the move done at time ``t`` (s, array_like) of a trapezoidal profile."""
    times = np.clip(np.asarray(t, dtype=float), 0.0, duration)
    return _fraction(times, duration, speed, accel, distance)


def _fraction(
    t: np.ndarray, duration: float, speed: float, accel: float, distance: float
) -> np.ndarray:
    if distance == 0.0 or duration == 0.0:
        return np.ones_like(t)
    peak = min(speed, np.sqrt(accel * distance))  # cruise speed actually reached
    t_acc = peak / accel
    s = np.where(
        t < t_acc,
        0.5 * accel * t**2,
        np.where(
            t <= duration - t_acc,
            0.5 * accel * t_acc**2 + peak * (t - t_acc),
            distance - 0.5 * accel * (duration - t) ** 2,
        ),
    )
    return np.clip(s / distance, 0.0, 1.0)


@dataclass(frozen=True)
class JointMove:
    """A synchronous joint move: every joint starts and ends together (the leading joint's profile).

    Attributes
    ----------
    start, end : numpy.ndarray, shape (6,)
        Joints, rad.
    speed, accel : float
        Leading-joint speed (rad/s) and acceleration (rad/s^2).
    """

    start: np.ndarray
    end: np.ndarray
    speed: float
    accel: float

    @property
    def lead(self) -> float:
        return float(np.max(np.abs(self.end - self.start)))

    @property
    def duration(self) -> float:
        return trapezoid_duration(self.lead, self.speed, self.accel)

    def at(self, t: ArrayLike) -> np.ndarray:
        """Joints at time(s) ``t`` since the move's start, shape (..., 6), rad."""
        f = trapezoid_fraction(t, self.duration, self.speed, self.accel, self.lead)
        return self.start + np.asarray(f)[..., None] * (self.end - self.start)


def ringing(
    t: ArrayLike,
    amplitude_mm: float,
    direction: ArrayLike,
    frequency_hz: float = 8.0,
    decay_s: float = 0.15,
) -> np.ndarray:
    """Damped vibration of the tool after a stop: offset (shape (..., 3), mm) at ``t`` s."""
    t = np.asarray(t, dtype=float)
    envelope = amplitude_mm * np.exp(-t / decay_s) * np.cos(2.0 * np.pi * frequency_hz * t)
    return envelope[..., None] * np.asarray(direction, dtype=float)
