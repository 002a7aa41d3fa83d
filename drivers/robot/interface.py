"""The robot interface the measure loop uses, whatever drives the arm.

Two implementations: :class:`~drivers.robot.ur.device.UrRtdeRobot` (a
Universal Robots controller through ``ur-rtde``) and
:class:`~drivers.robot.sim.device.SimulatedRobot` (a "true" arm, no network).
Both pass the same behavioural tests (``tests/robot/test_robot_interface.py``).

Units: joint angles in rad, speeds in rad/s, accelerations in rad/s^2.
Failures are exceptions from :mod:`drivers.robot.errors`, never return codes.
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from calibrator.acquire import ports

N_JOINTS = 6


@dataclass(frozen=True)
class SafetyState:
    """Safety flags of the controller.

    Attributes
    ----------
    protective_stopped : bool
        The safety system stopped the arm; :meth:`Robot.clear_protective_stop` is needed.
    emergency_stopped : bool
        An e-stop is engaged.
    """

    protective_stopped: bool
    emergency_stopped: bool

    @property
    def ok(self) -> bool:
        """True when neither stop is active."""
        return not (self.protective_stopped or self.emergency_stopped)


class Robot(ports.Robot):
    """Base class of every robot driver: the one robot contract plus ``with`` support.

    The contract itself (methods, units, failures, capabilities) is
    :class:`calibrator.acquire.ports.Robot`; this class adds nothing to it
    but :meth:`__enter__`/:meth:`__exit__` (``with robot: ...`` connects and
    closes). A driver declares what it can do beyond the contract in
    ``capabilities`` (names from :mod:`calibrator.acquire.ports`).
    """

    capabilities: frozenset[str] = frozenset()
    #: Who the arm is, for the journal (``open_robot`` sets it: ``ur://HOST:MODEL``).
    device_id: str = ""

    def __enter__(self):
        self.connect()
        return self

    def __exit__(self, *exc):
        self.close()


def real_array(value: Any, name: str) -> np.ndarray:
    """``value`` as a float array, refusing anything that is not real numbers.

    ``np.asarray(value, dtype=float)`` alone drops the imaginary part of a
    complex target (with only a warning), turns booleans into 0/1 and parses
    strings: each of those would move the arm somewhere nobody asked for.

    Raises
    ------
    ValueError
        If the values are complex, boolean, text, objects or otherwise not
        integer or floating point.
    """
    arr = np.asarray(value)
    if arr.dtype.kind not in "iuf":
        raise ValueError(f"{name} must hold real numbers, got {arr.dtype} values: {value!r}")
    return arr.astype(float)


def real_scalar(value: object, name: str) -> float:
    """``value`` as a float, refusing bools, complex numbers, text and arrays.

    Raises
    ------
    ValueError
    """
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
        raise ValueError(f"{name} must be a real number, got {value!r}")
    return float(value)


def check_move_args(q_rad: ArrayLike, speed_rad_s: float, accel_rad_s2: float) -> np.ndarray:
    """Validate the arguments of :meth:`Robot.move_joints`.

    Returns
    -------
    q : ndarray, shape (6,)
        The target as a float array, rad.

    Raises
    ------
    ValueError
        Wrong shape, values that are not real numbers (complex, bool, text),
        non-finite values or non-positive speed/acceleration.
    """
    q = real_array(q_rad, "joint target")
    if q.shape != (N_JOINTS,):
        raise ValueError(f"joint target must have shape (6,), got {q.shape}")
    if not np.all(np.isfinite(q)):
        raise ValueError(f"joint target must be finite, got {q}")
    for name, value in (("speed_rad_s", speed_rad_s), ("accel_rad_s2", accel_rad_s2)):
        number = real_scalar(value, name)
        if not (np.isfinite(number) and number > 0):
            raise ValueError(f"{name} must be finite and > 0, got {value}")
    return q
