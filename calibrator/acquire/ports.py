"""The two ports the measure loop drives: a laser tracker and a robot arm.

A driver implements a port by shape (``typing.Protocol``: no base class
needed) and reports the failures the loop acts on by raising exceptions that
derive from the classes below. Drivers derive their own error classes from
these as well as from their own tree (``drivers.errors.DriverError``), so the
loop can tell "measure this pose again" from "the arm has stopped" without
knowing which brand of tracker or robot it talks to.

Units: mm and rad; points and orientations in the tracker frame; joint
angles in rad.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

# ---------------------------------------------------------------- failures


class PortError(Exception):
    """Base of the failures a port reports to the measure loop."""


class ReadingLost(PortError):
    """This reading (or set of readings) is unusable; measure the pose again.

    Beam broken, target unstable, a reply lost to a timeout or a garbled frame.
    The tracker is still there: the loop discards the pose's readings and
    re-measures it, a bounded number of times.
    """


class TrackerUnavailable(PortError):
    """The tracker link is gone and the driver's own reconnects did not bring it back."""


class RobotHalted(PortError):
    """The arm's safety system stopped it (protective stop or e-stop).

    The loop ends the run cleanly, keeping every finished pose; an operator
    clears the stop and resumes.
    """


# ---------------------------------------------------------------- ports


@runtime_checkable
class TrackerReading(Protocol):
    """One tracker reading, tracker frame.

    Attributes
    ----------
    point_mm : numpy.ndarray, shape (3,)
        Target position, mm.
    rotvec_rad : numpy.ndarray, shape (3,), or None
        Probe orientation (probe to tracker frame) as a rotation vector, rad;
        None for a plain reflector.
    accurate : bool
        False when the tracker flagged the reading (inaccurate, unstable).
    device_time_us : int
        Tracker clock at the reading, microseconds.
    """

    point_mm: np.ndarray
    rotvec_rad: np.ndarray | None
    device_time_us: int

    @property
    def accurate(self) -> bool: ...


@runtime_checkable
class Tracker(Protocol):
    """A laser tracker, connected and ready to take stationary readings.

    ``measure`` raises :class:`ReadingLost` (or a subclass) when the reading
    is unusable and :class:`TrackerUnavailable` when the link is gone.
    """

    def connect(self) -> object:
        """Open the link, set units to mm and rad; never initialises (that moves the head)."""

    def measure(self, timeout_s: float | None = None) -> TrackerReading:
        """One stationary reading, bounded by ``timeout_s`` (s) or the driver's default."""

    def close(self) -> None:
        """Close the link; safe to call twice or after a failure."""


@runtime_checkable
class Robot(Protocol):
    """A 6-axis arm that moves in joint space (rad) and reports its joints.

    ``move_joints`` raises :class:`RobotHalted` (or a subclass) when the
    safety system stops the arm.
    """

    def connect(self) -> object: ...

    def close(self) -> None: ...

    def move_joints(self, q_rad, speed_rad_s: float, accel_rad_s2: float) -> np.ndarray:
        """Move to ``q_rad`` (shape (6,), rad), wait until steady; actual joints, shape (6,)."""

    def actual_joints(self) -> np.ndarray:
        """Actual joint angles, rad, shape (6,)."""

    def stop(self) -> None: ...
