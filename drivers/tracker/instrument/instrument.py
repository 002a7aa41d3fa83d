"""The simulated laser tracker itself, whatever wire it speaks.

:class:`Instrument` is the hardware both simulated front-ends drive: the
line protocol's (:mod:`drivers.tracker.line.simulator`) and Leica emScon's
(:mod:`drivers.tracker.emscon.simulator`). It holds the true target (still,
or moving along a path on the tracker's clock), the noise and its generator,
the fault script and the faults it has left running (a broken beam, unstable
or inaccurate readings), initialisation, the air its station's sensors
measure, its time since power-on (warm-up) and the latency of its stamps.
The front-ends only decode commands and encode replies.

No I/O, no protocol here. Its lock is re-entrant: a front-end holds it over
one whole command and may call any method inside.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike

# The one import of the simulated world's noise model (anisotropic, range-dependent).
from calibrator.model.noise import NoiseModel, beam_frame  # noqa: F401 - beam_frame: re-exported
from drivers.tracker.instrument.faults import Fault, FaultSchedule, parse_fault

MIN_RANGE_MM = 500.0  # closer than this a real tracker cannot lock on
MAX_RANGE_MM = 80_000.0
UNSTABLE_SIGMA_MM = 0.05  # extra scatter of a moving target ("outliers of tens of um")
#: Time a tracker needs after power-on before it measures to its specification, s
#: (a Leica AT960: about two hours; its warm-up errors reach tenths of a millimetre).
WARM_UP_S = 2 * 3600.0
#: Time since power-on a simulated tracker starts with unless told, s: warmed up.
ON_S = 3 * 3600.0
#: Most waypoints a path may hold (bounds the memory a client can take).
MAX_WAYPOINTS = 200_000
#: Air a tracker's station reads at a standard laboratory: degC, hPa, %RH.
STANDARD_AIR = (20.0, 1013.25, 50.0)


class Instrument:
    """A laser tracker at the origin of the tracker frame, measuring one target.

    Parameters
    ----------
    seed : int
        Seed of the noise generator (``numpy.random.default_rng``).
    noise : NoiseModel, optional
        Noise model; ``NoiseModel(enabled=False)`` for exact readings.
    faults : list of Fault, optional
        Faults armed from the start.
    init_time_s : float
        Duration of an initialisation, s (a real tracker takes tens of seconds).
    initialised : bool
        Start already initialised (a tracker that was initialised earlier).
    clock : callable
        Monotonic clock in seconds (the tracker's clock counts from its first call).
    air : tuple of 3 float
        What the station's sensors measure of the air: degC, hPa, %RH.
    on_s : float
        Time since power-on at start, s (warmed up after :data:`WARM_UP_S`).
    latency_s : float
        How late the tracker's stamps are: a reading stamped ``t`` shows a
        moving target where it was at ``t - latency_s`` (device clock, s).
    time_scale : float
        How many times faster than the wall clock ``clock`` runs.

    Attributes
    ----------
    lock : threading.RLock
        Held by a front-end over each command; target updates may come from
        another thread.
    faults : FaultSchedule
        The armed faults, counted by the front-ends under the line protocol's
        command names.
    target : numpy.ndarray or None
        True target now, shape (3,), mm, tracker frame.
    rotvec : numpy.ndarray
        True probe orientation (probe to tracker frame), rotation vector, shape (3,), rad.
    beam_broken_left, unstable_left, inaccurate_left : int
        Readings still refused (beam broken) or flagged, from faults that fired.
    """

    def __init__(
        self,
        *,
        seed: int = 0,
        noise: NoiseModel | None = None,
        faults: list[Fault] | None = None,
        init_time_s: float = 0.2,
        initialised: bool = False,
        clock: Callable[[], float] = time.monotonic,
        air: tuple[float, float, float] = STANDARD_AIR,
        on_s: float = ON_S,
        latency_s: float = 0.0,
        time_scale: float = 1.0,
    ):
        self.rng = np.random.default_rng(seed)
        self.noise = noise if noise is not None else NoiseModel()
        self.faults = FaultSchedule(faults)
        self.init_time_s = init_time_s
        self.initialised = initialised
        self.clock = clock
        self.t0 = clock()
        self.lock = threading.RLock()
        self.target: np.ndarray | None = None
        self.rotvec = np.zeros(3)
        self.range_mm = 0.0
        self.noise_scale: np.ndarray | None = None
        self.beam_broken_left = 0
        self.unstable_left = 0
        self.inaccurate_left = 0
        self.air = tuple(float(v) for v in air)
        self.on_s0 = float(on_s)
        self.latency_s = float(latency_s)
        self.time_scale = float(time_scale)
        # A moving target: device time (s) -> 3 or 6 values (mm, rad); None: still.
        self.motion: Callable[[float], ArrayLike] | None = None
        self.waypoints: list[list[float]] = []  # t (s), x, y, z (mm)[, rx, ry, rz (rad)]

    # ------------------------------------------------------------ the target

    def set_target(self, point_mm: ArrayLike, rotvec_rad: ArrayLike | None = None) -> None:
        """Where the target truly is, held still; re-acquires a broken beam.

        Parameters
        ----------
        point_mm : array_like, shape (3,)
            True target position in the tracker frame, mm.
        rotvec_rad : array_like, shape (3,), optional
            True probe orientation (probe to tracker frame) as a rotation
            vector, rad; zero rotation when omitted.

        Raises
        ------
        ValueError
            A value that is not finite.
        """
        with self.lock:
            self._place(point_mm, rotvec_rad)
            self.motion = None

    def _place(self, point_mm: ArrayLike, rotvec_rad: ArrayLike | None) -> None:
        point = np.asarray(point_mm, dtype=float).reshape(3)
        rot = np.zeros(3) if rotvec_rad is None else np.asarray(rotvec_rad, float).reshape(3)
        if not (np.all(np.isfinite(point)) and np.all(np.isfinite(rot))):
            raise ValueError("target position and orientation must be finite")
        self.target, self.rotvec = point, rot
        self.beam_broken_left = 0
        # Per-target constants, computed once: a reading must cost microseconds.
        self.range_mm = float(np.linalg.norm(point))
        self.noise_scale = self.noise.scale_matrix(point) if self.range_mm > 0 else None

    def clear_target(self) -> None:
        """Remove the target (the beam has nothing to lock on)."""
        with self.lock:
            self.target = None
            self.motion = None

    def set_motion(self, motion: Callable[[float], ArrayLike] | None) -> None:
        """Move the target along ``motion`` (None: hold it where it is now).

        Parameters
        ----------
        motion : callable or None
            ``motion(t_s)`` with ``t_s`` the device time in seconds
            (:meth:`device_time_s`) gives the true target: shape (3,), mm,
            tracker frame, or (6,) with the probe's rotation vector, rad.
            Readings show it at their stamp less :attr:`latency_s`.
            Re-acquires a broken beam, as :meth:`set_target`.
        """
        with self.lock:
            if motion is None:
                self.motion = None
                return
            self._place(*split_pose(motion(self.device_time_s())))
            self.motion = motion

    def pose_at(self, t_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """True point (3,) mm, rotation vector (3,) rad and noise scale (3, 3) or None of
        the target as read by a reading stamped ``t_s`` (device s); a target is set."""
        if self.motion is None:
            return self.target, self.rotvec, self.noise_scale  # type: ignore[return-value]
        point, rot = split_pose(self.motion(t_s - self.latency_s))
        scale = self.noise.scale_matrix(point) if np.linalg.norm(point) > 0 else None
        return point, (self.rotvec if rot is None else rot), scale

    @property
    def locked_on(self) -> bool:
        """Whether the beam is on a target (one is set and the beam is not broken)."""
        return self.target is not None and not self.beam_broken_left

    # ------------------------------------------------------------ a path of waypoints

    def clear_path(self) -> None:
        """Forget the waypoints collected so far."""
        with self.lock:
            self.waypoints = []

    def add_waypoint(self, values: list[float]) -> None:
        """One waypoint: ``t`` (s from the path's start, increasing), x, y, z (mm)
        and optionally the probe's rotation vector (rad).

        Raises
        ------
        ValueError
            Time not increasing, too many waypoints, or with and without orientation mixed.
        """
        with self.lock:
            if self.waypoints and values[0] <= self.waypoints[-1][0]:
                raise ValueError(f"waypoint time {values[0]} s does not increase")
            if len(self.waypoints) >= MAX_WAYPOINTS:
                raise ValueError(f"more than {MAX_WAYPOINTS} waypoints")
            if self.waypoints and len(values) != len(self.waypoints[-1]):
                raise ValueError("waypoints mix positions with and without orientation")
            self.waypoints.append(list(values))

    def start_path(self, delay_s: float) -> float:
        """Move the target through the waypoints, linear in between and held before and
        after, from ``delay_s`` after now on the tracker's clock; returns that start, s.

        Raises
        ------
        ValueError
            No waypoints, or a delay outside 0..3600 s.
        """
        with self.lock:
            if not self.waypoints:
                raise ValueError("no waypoints")
            if not 0.0 <= delay_s <= 3600.0:
                raise ValueError(f"start delay {delay_s} s outside 0..3600")
            table = np.array(self.waypoints)
            start = self.device_time_s() + delay_s

            def motion(t_s: float) -> np.ndarray:
                return np.array(
                    [np.interp(t_s - start, table[:, 0], col) for col in table[:, 1:].T]
                )

            self.set_motion(motion)
            return start

    # ------------------------------------------------------------ faults

    def arm_fault(self, fault: Fault | str) -> None:
        """Arm one fault (a :class:`Fault` or a fault-script line)."""
        with self.lock:
            self.faults.arm(parse_fault(fault) if isinstance(fault, str) else fault)

    def fire(self, fault: Fault) -> None:
        """The tracker's part of a fault that fired: ``not_initialised`` forgets the
        initialisation; ``beam_break``, ``unstable`` and ``inaccurate`` hold for the
        fault's ``count`` readings. Other kinds are the wire's (the front-end's)."""
        if fault.kind == "not_initialised":
            self.initialised = False
        elif fault.kind == "beam_break":
            self.beam_broken_left = fault.count
        elif fault.kind == "unstable":
            self.unstable_left = fault.count
        elif fault.kind == "inaccurate":
            self.inaccurate_left = fault.count

    def take_broken_reading(self) -> tuple[bool, bool]:
        """``(refused, restored)``: whether a broken beam refuses this reading (consuming
        one of the refusals), and whether the beam re-locks after it."""
        if not self.beam_broken_left:
            return False, False
        self.beam_broken_left -= 1
        return True, not self.beam_broken_left

    def take_unstable(self) -> bool:
        """Whether this reading is unstable (consumes one)."""
        if not self.unstable_left:
            return False
        self.unstable_left -= 1
        return True

    def take_inaccurate(self) -> bool:
        """Whether this reading is flagged inaccurate (consumes one)."""
        if not self.inaccurate_left:
            return False
        self.inaccurate_left -= 1
        return True

    # ------------------------------------------------------------ readings

    @staticmethod
    def in_range(point_mm: np.ndarray) -> bool:
        """Whether a target at ``point_mm`` (shape (3,), mm) is within the beam's reach."""
        return MIN_RANGE_MM <= float(np.linalg.norm(point_mm)) <= MAX_RANGE_MM

    def sample_point(self, point_mm: np.ndarray, scale: np.ndarray | None) -> np.ndarray:
        """One noisy reading (shape (3,), mm) of a target at ``point_mm``; ``scale``
        is the noise's :meth:`~NoiseModel.scale_matrix` there, if known."""
        return self.noise.sample_point(point_mm, self.rng, scale)

    def sample_rotvec(self, rotvec_rad: np.ndarray) -> np.ndarray:
        """One noisy probe orientation (rotation vector, shape (3,), rad)."""
        return self.noise.sample_rotvec(rotvec_rad, self.rng)

    def scatter(self, point_mm: np.ndarray) -> np.ndarray:
        """An unstable target's reading: ``point_mm`` plus :data:`UNSTABLE_SIGMA_MM` scatter."""
        return point_mm + self.rng.normal(0.0, UNSTABLE_SIGMA_MM, 3)

    # ------------------------------------------------------------ clock, air, warm-up

    def device_time_s(self) -> float:
        """The tracker's clock now, s (its readings carry it)."""
        return self.device_s(self.clock())

    def device_s(self, now: float) -> float:
        """The tracker's clock at ``clock()`` time ``now``, s."""
        return now - self.t0

    def on_s(self, now: float) -> float:
        """Time since power-on at ``clock()`` time ``now``, s."""
        return self.on_s0 + (now - self.t0)

    def warmed_up(self, now: float) -> bool:
        """Whether the tracker measures to its specification at ``clock()`` time ``now``."""
        return self.on_s(now) >= WARM_UP_S


def split_pose(values: ArrayLike) -> tuple[np.ndarray, np.ndarray | None]:
    """``(point (3,), rotvec (3,) or None)`` from 3 or 6 values; finite, else ValueError."""
    v = np.asarray(values, dtype=float).ravel()
    if v.shape not in ((3,), (6,)) or not np.all(np.isfinite(v)):
        raise ValueError(f"a target is 3 or 6 finite values, got {v.shape}")
    return v[:3], (v[3:] if len(v) == 6 else None)
