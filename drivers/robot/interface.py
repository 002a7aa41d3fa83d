"""The robot interface the measure loop uses, whatever drives the arm.

Two implementations: :class:`~drivers.robot.ur_rtde_adapter.UrRtdeRobot` (a
Universal Robots controller through ``ur-rtde``) and
:class:`~drivers.robot.simulated.SimulatedRobot` (a "true" arm, no network).
Both pass the same behavioural tests (``tests/robot/test_robot_interface.py``).

Units: joint angles in rad, speeds in rad/s, accelerations in rad/s^2.
Failures are exceptions from :mod:`drivers.robot.errors`, never return codes.
"""

import abc
import numbers
from dataclasses import dataclass

import numpy as np

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
    def ok(self):
        """True when neither stop is active."""
        return not (self.protective_stopped or self.emergency_stopped)


class Robot(abc.ABC):
    """A 6-axis arm that moves in joint space and reports its joints.

    Use as a context manager (``with robot: ...``) or call :meth:`connect`
    and :meth:`close`.
    """

    @abc.abstractmethod
    def connect(self):
        """Open the link to the arm; raises :class:`~drivers.errors.ConnectionLost` if it fails."""

    @abc.abstractmethod
    def close(self):
        """Close the link; safe to call twice or after a failure."""

    @abc.abstractmethod
    def move_joints(self, q_rad, speed_rad_s, accel_rad_s2):
        """Move to joint angles, wait until steady, and check the arm got there.

        Parameters
        ----------
        q_rad : array_like, shape (6,)
            Target joint angles, rad.
        speed_rad_s : float
            Speed of the leading joint, rad/s (> 0).
        accel_rad_s2 : float
            Acceleration of the leading joint, rad/s^2 (> 0).

        Returns
        -------
        ndarray, shape (6,)
            Actual joint angles (rad) once steady, within tolerance of ``q_rad``.

        Raises
        ------
        ProtectiveStop, EmergencyStop
            The arm is (or became) stopped by its safety system.
        MotionFailed
            The move ended away from its target (e.g. :meth:`stop` was called).
        ConnectionLost, DriverTimeout
            The link went away, or the move did not end by its deadline.
        """

    @abc.abstractmethod
    def actual_joints(self):
        """Actual joint angles, rad, shape (6,)."""

    @abc.abstractmethod
    def safety_state(self):
        """Current :class:`SafetyState`."""

    @abc.abstractmethod
    def stop(self):
        """Stop any motion now (callable from another thread while a move waits)."""

    @abc.abstractmethod
    def clear_protective_stop(self):
        """Release a protective stop and make the arm accept moves again.

        Raises
        ------
        EmergencyStop
            An e-stop is still engaged (only an operator can release it).
        NotReady
            The controller refused to release the stop (yet).
        """

    def __enter__(self):
        self.connect()
        return self

    def __exit__(self, *exc):
        self.close()


def real_array(value, name):
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


def real_scalar(value, name):
    """``value`` as a float, refusing bools, complex numbers, text and arrays.

    Raises
    ------
    ValueError
    """
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
        raise ValueError(f"{name} must be a real number, got {value!r}")
    return float(value)


def check_move_args(q_rad, speed_rad_s, accel_rad_s2):
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
