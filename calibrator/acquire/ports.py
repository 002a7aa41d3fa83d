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

from abc import abstractmethod
from collections.abc import Callable
from contextlib import ExitStack
from dataclasses import dataclass
from typing import Any, Generic, Protocol, TypeGuard, TypeVar, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike

# ---------------------------------------------------------------- failures


class PortError(Exception):
    """Base of the failures a port reports to the measure loop."""


class ReadingLost(PortError):
    """This reading (or set of readings) is unusable; measure the pose again.

    Beam broken, target unstable, a reply lost to a timeout or a garbled frame.
    The tracker is still there: the loop discards the pose's readings and
    re-measures it, a bounded number of times.
    """


class BeamLost(ReadingLost):
    """The beam is broken or not locked on the reflector: someone (or a search) must re-lock it."""


class BadReading(ReadingLost):
    """A reading whose numbers cannot be true (NaN, infinite, beyond any tracker's range)."""


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


# ---------------------------------------------------------------- capabilities
#
# What a device can do beyond the contract. The driver declares each one in
# its ``capabilities`` (a frozenset of the names below) rather than leaving the
# loop to probe with hasattr: a wrapper has every method of what it wraps but
# not always the ability (a guarded robot forwards ``joint_temperatures``
# only to arms that report them; a replaying simulator asks no conditions).
# Each name is also a small runtime-checkable protocol of the methods it
# promises, so ``CAPABILITY.offered_by(device)`` checks both the declaration
# and the methods, and the type checker then knows the methods exist.

C = TypeVar("C")


class Capability(str, Generic[C]):
    """A capability's name (a ``str``, as drivers declare it) tied to its protocol.

    Parameters
    ----------
    name : str
        What drivers put in ``capabilities``.
    protocol : type
        The ``@runtime_checkable`` protocol of the methods it promises.
    """

    protocol: type

    def __new__(cls, name: str, protocol: type) -> Capability[C]:
        self = super().__new__(cls, name)
        self.protocol = protocol
        return self

    def offered_by(self, device: object) -> TypeGuard[C]:
        """``device`` declares this capability and has the protocol's methods."""
        return self in getattr(device, "capabilities", ()) and isinstance(device, self.protocol)


@runtime_checkable
class Initialisable(Protocol):
    """A tracker that can be initialised (it moves the head)."""

    def initialise(self, timeout_s: float | None = None) -> None: ...


@runtime_checkable
class FindsReflector(Protocol):
    """A tracker that can search for its reflector near a predicted position after a lost beam.

    ``predicted_point_mm``: shape (3,), tracker frame, mm; the loop predicts it as the
    last point measured.
    """

    def find_reflector(self, predicted_point_mm: ArrayLike) -> None: ...


@runtime_checkable
class Steerable(Protocol):
    """A simulated tracker told where its reflector really is.

    ``point_mm``: shape (3,), mm, tracker frame; ``rotvec_rad``: the probe's orientation
    (probe to tracker frame), rotation vector, shape (3,), rad, or None.
    """

    def set_target(self, point_mm: np.ndarray, rotvec_rad: np.ndarray | None = None) -> None: ...


@runtime_checkable
class ReportsConditions(Protocol):
    """A tracker that reports what it measures of its surroundings.

    ``conditions()`` returns a dict (``air_temperature_c``, ``air_pressure_hpa``,
    ``air_humidity_pct``, ``on_s``: time since power-on, ``warmed_up``; any may be
    None when it does not say), or None.
    """

    def conditions(self) -> dict | None: ...


@runtime_checkable
class ChecksPlan(Protocol):
    """A robot that checks a whole plan against its motion limits before the first move.

    ``plan_rad``: shape (N, 6), rad; speed in rad/s, acceleration in rad/s^2.
    Raises ``ValueError`` naming the first violation.
    """

    def check_plan(self, plan_rad: np.ndarray, speed_rad_s: float, accel_rad_s2: float) -> None: ...


@runtime_checkable
class ReportsTruePose(Protocol):
    """A simulated robot that calls ``listener(tool2tracker)`` (4x4, mm) after each move,
    so a simulated tracker can follow the true probe."""

    listener: Callable[[np.ndarray], object] | None


@runtime_checkable
class FollowsPath(Protocol):
    """A robot that runs a timed joint path while the tracker streams it.

    ``follow_path(t_s, q_rad, delay_s)``: hold at ``q_rad[0]`` for ``delay_s``
    (s), then pass through the joint commands ``q_rad`` (N, 6), rad, at the
    times ``t_s`` (N,), s from the start of the motion; returns that start on
    the clock of the tracker that streams it, microseconds (the path test
    aligns the stream with it). The simulated robot runs it on the simulated
    tracker's target (:mod:`drivers.robot.sim.follow`).
    """

    def follow_path(self, t_s: np.ndarray, q_rad: np.ndarray, delay_s: float = 0.0) -> int: ...


@runtime_checkable
class RunsPath(Protocol):
    """A simulated tracker whose target runs a timed path (what a following arm steers).

    ``run_path(t_s, point_mm, delay_s, rotvec_rad)``: points (N, 3), mm, tracker
    frame, at ``t_s`` (N,), s, after ``delay_s``, the probe turned through
    ``rotvec_rad`` (N, 3), rad (probe to tracker frame; None: not turned);
    returns the start on its clock, us.
    """

    def run_path(
        self,
        t_s: np.ndarray,
        point_mm: np.ndarray,
        delay_s: float = 0.0,
        rotvec_rad: np.ndarray | None = None,
    ) -> int: ...


@runtime_checkable
class ReportsTemperatures(Protocol):
    """A robot that reports its joints' temperatures, shape (6,), degC."""

    def joint_temperatures(self) -> np.ndarray: ...


#: The tracker can be initialised (``initialise(timeout_s=None)``; moves the head).
INITIALISE: Capability[Initialisable] = Capability("initialise", Initialisable)
#: The tracker searches for its reflector near a predicted position after a lost beam.
SEARCH: Capability[FindsReflector] = Capability("search", FindsReflector)
#: A simulated tracker told where its reflector really is (``set_target``).
STEER: Capability[Steerable] = Capability("steer", Steerable)
#: The robot runs a timed joint path the tracker streams (``follow_path``).
FOLLOW_PATH: Capability[FollowsPath] = Capability("follow_path", FollowsPath)
#: The tracker reports its surroundings (``conditions()``).
REPORTS_CONDITIONS: Capability[ReportsConditions] = Capability(
    "reports_conditions", ReportsConditions
)
#: The robot checks a whole plan against its motion limits (``check_plan``).
CHECKS_PLAN: Capability[ChecksPlan] = Capability("checks_plan", ChecksPlan)
#: A simulated robot reports where its probe truly is after each move (``listener``).
REPORTS_TRUE_POSE: Capability[ReportsTruePose] = Capability("reports_true_pose", ReportsTruePose)
#: The robot reports its joints' temperatures (``joint_temperatures()``).
REPORTS_TEMPERATURES: Capability[ReportsTemperatures] = Capability(
    "reports_temperatures", ReportsTemperatures
)
#: The robot moves real hardware: the user must confirm before it moves (a
#: declaration only: no methods come with it).
MOVES_HARDWARE = "moves_hardware"


class TrackerState(Protocol):
    """What ``Tracker.connect`` and ``Tracker.status`` return (at least)."""

    @property
    def initialised(self) -> bool: ...


@runtime_checkable
class Tracker(Protocol):
    """A laser tracker, ready to take stationary readings once connected.

    ``measure`` raises :class:`ReadingLost` (or a subclass) when the reading
    is unusable and :class:`TrackerUnavailable` when the link is gone; any
    failure of ``connect`` is an ``OSError`` or a :class:`PortError`.

    Attributes
    ----------
    capabilities : frozenset of str
        Which of :data:`INITIALISE`, :data:`SEARCH`, :data:`STEER` it offers.
    device_id : str
        Who answered (vendor, model and serial), known after ``connect``; a
        journal records it and a resume must find the same.
    """

    capabilities: frozenset[str]

    @property
    def device_id(self) -> str: ...

    def connect(self) -> TrackerState:
        """Open the link, set units to mm and rad; never initialises (that moves the head)."""
        ...

    def status(self) -> TrackerState:
        """The tracker's state now (initialised or not, ...)."""
        ...

    def measure(self, timeout_s: float | None = None) -> TrackerReading:
        """One stationary reading, bounded by ``timeout_s`` (s) or the driver's default."""
        ...

    def close(self) -> None:
        """Close the link; safe to call twice or after a failure."""
        ...


class Robot(Protocol):
    """The one robot contract: a 6-axis arm moving in joint space (rad), reporting its joints.

    Every robot driver implements it (``drivers.robot.interface.Robot`` is
    its base class with the context-manager methods) and the measure loop
    uses nothing else. Failures are exceptions, never return codes:
    :class:`RobotHalted` (or a subclass) when the safety system stops the
    arm, any other ``OSError`` for a lost link or a move that failed.

    Units: joint angles in rad, speeds in rad/s, accelerations in rad/s^2.

    Attributes
    ----------
    capabilities : frozenset of str
        Which of :data:`MOVES_HARDWARE`, :data:`CHECKS_PLAN`,
        :data:`REPORTS_TRUE_POSE`, :data:`REPORTS_TEMPERATURES` it offers.
    """

    capabilities: frozenset[str] = frozenset()

    @abstractmethod
    def connect(self) -> object:
        """Open the link to the arm; raises ``ConnectionError`` (an ``OSError``) if it fails."""

    @abstractmethod
    def close(self) -> None:
        """Close the link; safe to call twice or after a failure."""

    @abstractmethod
    def move_joints(self, q_rad: ArrayLike, speed_rad_s: float, accel_rad_s2: float) -> np.ndarray:
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
        RobotHalted
            The arm is (or became) stopped by its safety system.
        OSError
            The move ended away from its target, the link went away, or the
            move did not end by its deadline.
        """

    @abstractmethod
    def actual_joints(self) -> np.ndarray:
        """Actual joint angles, rad, shape (6,)."""

    @abstractmethod
    def safety_state(self) -> object:
        """Current safety flags (``protective_stopped``, ``emergency_stopped``, ``ok``)."""

    @abstractmethod
    def stop(self) -> None:
        """Stop any motion now (callable from another thread while a move waits)."""

    @abstractmethod
    def clear_protective_stop(self) -> None:
        """Release a protective stop and make the arm accept moves again.

        Raises
        ------
        RobotHalted
            An e-stop is still engaged (only an operator can release it).
        OSError
            The controller refused to release the stop (yet).
        """


# ---------------------------------------------------------------- the devices of a run


@dataclass(frozen=True)
class Opened:
    """The devices a :class:`Devices` opened for one run (not connected yet).

    A simulated cell's tracker already follows its arm (the devices wired
    that); what a procedure may know of the simulated cell comes as plain
    data, None on real hardware.

    Attributes
    ----------
    robot : calibrator.acquire.ports.Robot or calibrator.acquire.external.arm.ProgramArm
    tracker : calibrator.acquire.ports.Tracker
    tracker_at_mm : numpy.ndarray, shape (3,), optional
        Where the tracker stands, robot base frame, mm, when the devices know
        it (the simulated cell); None: only the run's options say.
    surveyed_base2tracker : numpy.ndarray, shape (4, 4), optional
        The robot base in the tracker frame, mm, as a survey of the cell gives
        it (the simulated cell: its truth plus a seeded survey error); None
        on real hardware (a user surveys it, ``verify --register``).
    """

    robot: Any
    tracker: Tracker
    tracker_at_mm: np.ndarray | None = None
    surveyed_base2tracker: np.ndarray | None = None


class Devices(Protocol):
    """The port through which a procedure opens its robot and tracker.

    ``drivers.devices.Devices`` implements it over the drivers' URL registries.
    """

    #: The tracker's URL, as messages name it.
    tracker_url: str

    def open(
        self, arm: Any, seed: int, place_tracker_at: Any, stack: ExitStack
    ) -> Opened:  # pragma: no cover - a protocol
        """Open both devices for ``arm`` (unconnected); register their clean-up on ``stack``.

        ``seed`` seeds a simulated cell; ``place_tracker_at`` (robot base frame,
        mm, or None) is where a simulated tracker is put.
        """
        ...

    def tracker_at_mm(self, arm: Any, seed: int) -> tuple[float, float, float] | None:
        """Where the tracker stands before anything opens (a simulated cell's), else None."""
        ...  # pragma: no cover - a protocol
