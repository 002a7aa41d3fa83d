"""What every program writer is given: the plan, home pose, motion caps, dwell and pulse."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from calibrator.errors import CalibrationError

#: Decimals written for angles: 1e-6 deg and 1e-9 rad, far below the 1e-6 rad round trip
#: (a controller storing 32-bit floats keeps about 3e-7 rad at 180 deg).
DEG_DECIMALS = 6
RAD_DECIMALS = 9
#: Length of the optional digital-output pulse at each arrival, s.
PULSE_S = 0.1


@dataclass(frozen=True)
class ProgramSpec:
    """A measurement program, language-free.

    Attributes
    ----------
    plan_rad : numpy.ndarray, shape (N, 6)
        Joint targets in plan order, rad.
    home_rad : numpy.ndarray, shape (6,)
        Safe start and end pose, rad.
    speed_rad_s, accel_rad_s2 : float
        Leading-joint speed and acceleration caps, rad/s and rad/s^2.
    max_joint_speed_rad_s : numpy.ndarray, shape (6,)
        Each axis's rated top speed, rad/s (for languages that set speed as a percentage).
    dwell_s : float
        Wait at each pose, s.
    pulse_output : int or None
        Digital output pulsed for :data:`PULSE_S` at each arrival (None: no pulse).
    name : str
        Program (procedure) name.
    model : str
        The arm model, written in the header.
    via_rad : tuple of N ndarrays, shape (k_i, 6)
        Joint vectors moved through before pose i, rad (:attr:`calibrator.plan.Plan.via_rad`):
        joint moves without dwell or pulse, so the controller follows the path the plan
        checked in the cell. Default: none.
    """

    plan_rad: np.ndarray
    home_rad: np.ndarray
    speed_rad_s: float
    accel_rad_s2: float
    max_joint_speed_rad_s: np.ndarray
    dwell_s: float = 2.0
    pulse_output: int | None = None
    name: str = "calibrator_measure"
    model: str = ""
    via_rad: tuple = ()

    def __post_init__(self) -> None:
        plan = np.asarray(self.plan_rad, dtype=float)
        if plan.ndim != 2 or plan.shape[1] != 6 or not len(plan):
            raise CalibrationError(f"a program needs a plan of shape (N, 6), got {plan.shape}")
        via = tuple(np.asarray(v, dtype=float).reshape(-1, 6) for v in self.via_rad)
        if via and len(via) != len(plan):
            raise CalibrationError(f"{len(via)} via lists for {len(plan)} poses")
        object.__setattr__(self, "via_rad", via or tuple(np.zeros((0, 6)) for _ in plan))
        if np.asarray(self.home_rad).shape != (6,):
            raise CalibrationError("the home pose needs 6 joint angles")
        if not (self.speed_rad_s > 0 and self.accel_rad_s2 > 0):
            raise CalibrationError("speed and acceleration must be positive")
        if not self.dwell_s > PULSE_S:
            raise CalibrationError(f"dwell must be longer than the {PULSE_S} s pulse")
        if not self.name.isidentifier() or not self.name.isascii():
            raise CalibrationError(f"program name {self.name!r} is not an identifier")

    def moves(self) -> list[tuple[str, int | None, np.ndarray, np.ndarray]]:
        """Every joint move in order: ``(kind, pose, start_rad, end_rad)``.

        ``kind`` is ``home``, ``via`` (moved through before ``pose``: no dwell,
        no pulse) or ``pose`` (a measured pose: dwell, and pulse if asked).
        """
        out: list[tuple[str, int | None, np.ndarray, np.ndarray]] = []
        here = np.asarray(self.home_rad, dtype=float)
        out.append(("home", None, here, here))
        for pose, q in enumerate(np.asarray(self.plan_rad, dtype=float)):
            for via in self.via_rad[pose]:
                out.append(("via", pose, here, via))
                here = via
            out.append(("pose", pose, here, q))
            here = q
        out.append(("home", None, here, np.asarray(self.home_rad, dtype=float)))
        return out

    def speed_percent(self) -> np.ndarray:
        """Per-axis speed as a percentage of each axis's top speed, shape (6,), rounded down."""
        pct = 100.0 * self.speed_rad_s / np.asarray(self.max_joint_speed_rad_s, dtype=float)
        return np.clip(np.floor(pct * 10.0) / 10.0, 0.1, 100.0)


def trapezoid_duration_s(distance_rad: float, speed_rad_s: float, accel_rad_s2: float) -> float:
    """Duration of a rest-to-rest move of ``distance_rad`` with a trapezoidal speed profile, s.

    Triangular (accelerate, then brake) when the move is too short to reach the speed.
    """
    distance = abs(float(distance_rad))
    if distance == 0.0:
        return 0.0
    if distance >= speed_rad_s**2 / accel_rad_s2:
        return distance / speed_rad_s + speed_rad_s / accel_rad_s2
    return 2.0 * float(np.sqrt(distance / accel_rad_s2))


def move_duration_s(
    start_rad: ArrayLike, end_rad: ArrayLike, speed_rad_s: float, accel_rad_s2: float
) -> float:
    """Duration of a synchronous joint move whose leading joint keeps to the caps, s.

    ``start_rad`` and ``end_rad`` have shape (6,); a time-programmed move this
    long never exceeds either cap.
    """
    lead = float(np.max(np.abs(np.asarray(end_rad, float) - np.asarray(start_rad, float))))
    return trapezoid_duration_s(lead, speed_rad_s, accel_rad_s2)
