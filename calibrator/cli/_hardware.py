"""The concrete drivers behind ``calibrator measure``: the only place they are built.

Trackers and robots are chosen by URL scheme from two small registries, so a
new tracker brand (e.g. ``emscon://host:port``) is one entry in
:data:`TRACKERS` plus its adapter. ``sim`` (the default for both) is the
embedded simulated cell: a :class:`~drivers.robot.simulated.SimulatedRobot`
with hidden MDH errors and the tracker simulator as a child process behind a
real pty, so the whole wire protocol runs.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from calibrator import frames, kinematics
from calibrator.acquire.ports import ReadingLost, TrackerUnavailable
from calibrator.errors import CalibrationError
from calibrator.models import get_model
from calibrator.simulate import DEFAULT_TOOL_POINT, random_errors

#: The simulated cell: where the tracker stands in the robot base frame (mm) and
#: how it is turned (rotation vector, rad); roughly what a user would measure.
SIM_TRACKER_AT_MM = np.array([2500.0, 400.0, 300.0])
SIM_TRACKER_ROTVEC = np.array([0.05, -0.1, 2.8])


@dataclass
class SimCell:
    """The hidden truth of the simulated cell (seeded): the arm's errors, tool and tracker.

    Attributes
    ----------
    model : calibrator.models.RobotModel
    true_mdh : ndarray, shape (6, 5)
    base2tracker : ndarray, shape (4, 4)
    flange2tool : ndarray, shape (4, 4)
        The true tool; the session's first guess is :data:`DEFAULT_TOOL_POINT`.
    """

    model: object
    true_mdh: np.ndarray
    base2tracker: np.ndarray
    flange2tool: np.ndarray

    @classmethod
    def make(cls, model_name: str, seed: int) -> SimCell:
        model = get_model(model_name)
        rng = np.random.default_rng(seed)
        true_mdh = model.mdh + random_errors(model.mdh, rng, mm=0.5, rad=1e-3)
        offset = rng.standard_normal(3)
        offset *= 1.5 / np.linalg.norm(offset)  # an unknown 1.5 mm error of the tool point
        tool = frames.transform(translation=DEFAULT_TOOL_POINT + offset)
        tracker2base = frames.transform(
            frames.rotvec_to_matrix(SIM_TRACKER_ROTVEC), SIM_TRACKER_AT_MM
        )
        return cls(model, true_mdh, frames.invert(tracker2base), tool)

    def tool_pose(self, q_rad) -> np.ndarray:
        """True probe pose in the tracker frame for joints ``q_rad`` (6,), shape (4, 4), mm."""
        return kinematics.forward(
            self.true_mdh, np.asarray(q_rad, float)[None], self.flange2tool, self.base2tracker
        )[0]


class LaserTrackerPort:
    """The product's tracker protocol driver (:class:`drivers.tracker.LaserTracker`) as a port.

    The driver reconnects on its own; a ``ConnectionLost`` out of ``MEAS``
    means the reading is lost. If the link answers again the pose is measured
    again (:class:`ReadingLost`), otherwise the tracker is gone
    (:class:`TrackerUnavailable`).
    """

    def __init__(self, url, **driver_options):
        from drivers.tracker import LaserTracker

        self.url = url
        self.driver = LaserTracker(url, **driver_options)
        self.identity = None

    def connect(self):
        from drivers.errors import DriverError
        from drivers.tracker import Environment

        try:
            identity, status = self.driver.connect(Environment())
        except DriverError as exc:
            raise TrackerUnavailable(f"tracker at {self.url}: {exc}") from exc
        if not status.initialised:
            raise CalibrationError(
                f"tracker at {self.url} is not initialised: initialise it first (INIT moves "
                "the head), then run measure again"
            )
        self.identity = ":".join(identity.key)
        return identity

    def measure(self, timeout_s=None):
        from drivers.errors import ConnectionLost, DriverError
        from drivers.tracker import IdentityChanged

        try:
            return self.driver.measure(timeout_s)
        except ConnectionLost as exc:
            if isinstance(exc, IdentityChanged):
                raise TrackerUnavailable(str(exc)) from exc
            try:
                self.driver.status()  # reconnects when it can; raises when it cannot
            except DriverError as again:
                raise TrackerUnavailable(f"tracker at {self.url}: {again}") from exc
            raise ReadingLost(f"link dropped and came back: {exc}") from exc

    def close(self):
        self.driver.close()


@dataclass
class Rig:
    """What ``measure`` runs on: connected ports plus what the session and journal say.

    Attributes
    ----------
    robot, tracker : ports
    robot_id, tracker_id : str
        Identities written to the journal (a resume must match them).
    model : calibrator.models.RobotModel
    flange2tool_guess : ndarray, shape (4, 4)
    tracker_at_mm : ndarray, shape (3,), or None
        Rough tracker position in the base frame (plans use it).
    after_move : callable or None
    real_robot : bool
        A robot that moves for real (confirmation needed).
    """

    robot: object = None
    tracker: object = None
    robot_id: str = ""
    tracker_id: str = ""
    model: object = None
    flange2tool_guess: np.ndarray = field(
        default_factory=lambda: frames.transform(translation=DEFAULT_TOOL_POINT)
    )
    tracker_at_mm: np.ndarray | None = None
    after_move: Callable | None = None
    real_robot: bool = False
    sim_cell: SimCell | None = None
    # A robot that watches the tracker hands the loop its own view of it (external).
    tracker_view: Callable | None = None
    summary: Callable[[], list] | None = None


@dataclass(frozen=True)
class RigOptions:
    """Options ``measure`` passes through to the drivers."""

    model: str = "ur10e"
    seed: int = 0
    sim_noise: bool = True
    sim_faults: str | None = None
    sim_record: str | None = None
    sim_replay: str | None = None
    sim_control: str | None = None
    # None: the model's fixed ceiling; a value may only lower it.
    max_speed_rad_s: float | None = None
    max_accel_rad_s2: float | None = None
    tracker_at_mm: tuple | None = None
    external: object = None  # drivers.robot.external.ExternalOptions for --robot external


def scheme(url: str) -> str:
    """``sim``, ``ur``, ``socket``, ... : the part before ``://`` (a bare path is ``serial``)."""
    if url in ("sim", "external"):
        return url
    if "://" in url:
        return url.split("://", 1)[0].lower()
    return "serial"


# ------------------------------------------------------------------ robots


def _sim_robot(url, rig: Rig, options: RigOptions, stack) -> None:
    from drivers.robot.simulated import SimulatedRobot

    cell = rig.sim_cell
    rig.robot = SimulatedRobot(cell.true_mdh, cell.base2tracker, cell.flange2tool)
    rig.robot_id = f"sim:{cell.model.name}:seed={options.seed}"


def _ur_robot(url, rig: Rig, options: RigOptions, stack) -> None:
    from drivers.robot.safety import GuardedRobot, MotionLimits
    from drivers.robot.ur_rtde_adapter import UrRtdeRobot

    host = url.split("://", 1)[1].strip("/")
    if not host:
        raise CalibrationError("--robot ur:// needs a host, e.g. ur://192.168.1.10")
    limits = MotionLimits.from_model(rig.model, options.max_speed_rad_s, options.max_accel_rad_s2)
    rig.robot = GuardedRobot(UrRtdeRobot(host), limits)
    rig.robot_id = f"ur://{host}:{rig.model.name}"
    rig.real_robot = True


def _external_robot(url, rig: Rig, options: RigOptions, stack) -> None:
    from drivers.robot.external.setup import attach

    attach(rig, options.external)


ROBOTS: dict[str, Callable] = {"sim": _sim_robot, "ur": _ur_robot, "external": _external_robot}


# ---------------------------------------------------------------- trackers


def _sim_tracker(url, rig: Rig, options: RigOptions, stack) -> None:
    from drivers.tracker.simulator import SimulatorProcess

    sim = stack.enter_context(
        SimulatorProcess(
            seed=options.seed,
            noise=options.sim_noise,
            initialised=True,
            faults=options.sim_faults,
            replay=options.sim_replay,
        )
    )
    rig.tracker = LaserTrackerPort(sim.url, record=options.sim_record)
    cell = rig.sim_cell

    def place(point_mm):
        from drivers.errors import DriverError

        try:
            sim.set_target(point_mm)
        except (DriverError, OSError) as exc:  # the simulated tracker itself is gone
            raise TrackerUnavailable(f"tracker simulator: {exc}") from exc

    if rig.robot is not None and hasattr(rig.robot, "listener"):
        rig.robot.listener = lambda pose: place(pose[:3, 3])
    else:
        rig.after_move = lambda q: place(cell.tool_pose(q)[:3, 3])


def _line_tracker(url, rig: Rig, options: RigOptions, stack) -> None:
    rig.tracker = LaserTrackerPort(url)


class EmsconPort:
    """A Leica tracker through its emScon server (:mod:`drivers.tracker.emscon`) as a port.

    The adapter already raises the port's errors; here a failed connect becomes
    :class:`TrackerUnavailable` and an uninitialised tracker stops the run
    (``Initialize`` moves the head: only on the user's request).
    """

    def __init__(self, url, **adapter_options):
        from drivers.tracker.emscon import open_tracker

        self.url = url
        try:
            self.driver = open_tracker(url, **adapter_options)
        except ValueError as exc:
            raise CalibrationError(f"--tracker: {exc}") from None
        self.identity = None

    def connect(self):
        from drivers.errors import DriverError

        try:
            status = self.driver.connect()
        except DriverError as exc:
            raise TrackerUnavailable(f"tracker at {self.url}: {exc}") from exc
        if not status.initialised:
            raise CalibrationError(
                f"tracker at {self.url} is not initialised: initialise it first (it moves "
                "the head), then run measure again"
            )
        self.identity = f"emscon:serial={status.serial}"
        return status

    def measure(self, timeout_s=None):
        return self.driver.measure(timeout_s)

    def close(self):
        self.driver.close()


def _emscon_tracker(url, rig: Rig, options: RigOptions, stack) -> None:
    rig.tracker = EmsconPort(url)
    if options.sim_control is not None and hasattr(rig.robot, "listener"):
        # An emScon simulator process: the simulated robot tells it where its probe is.
        from drivers.tracker.simulator.launch import SimulatorControl

        try:
            control = SimulatorControl(options.sim_control)
        except (OSError, ValueError) as exc:
            raise CalibrationError(f"--sim-control {options.sim_control}: {exc}") from None
        stack.callback(control.close)
        rig.robot.listener = lambda pose: control.set_target(pose[:3, 3])


#: Tracker adapters by URL scheme. pyserial's URL schemes and bare device paths
#: go to the product's line-protocol driver.
TRACKERS: dict[str, Callable] = {
    "sim": _sim_tracker,
    "serial": _line_tracker,
    "socket": _line_tracker,
    "rfc2217": _line_tracker,
    "loop": _line_tracker,
    "emscon": _emscon_tracker,
}


def build(robot_url: str, tracker_url: str, options: RigOptions, stack) -> Rig:
    """Build and connect the robot and tracker named by their URLs.

    Parameters
    ----------
    stack : contextlib.ExitStack
        Receives every cleanup (child processes, links), run in reverse on exit.

    Raises
    ------
    CalibrationError
        Unknown scheme or a missing host.
    """
    robot_kind, tracker_kind = scheme(robot_url), scheme(tracker_url)
    if robot_kind not in ROBOTS:
        raise CalibrationError(f"unknown --robot {robot_url!r}; use sim or ur://HOST or external")
    if tracker_kind not in TRACKERS:
        raise CalibrationError(
            f"unknown --tracker {tracker_url!r}; use sim, a device path or one of "
            + ", ".join(f"{k}://" for k in TRACKERS if k not in ("sim", "serial"))
        )
    rig = Rig(model=get_model(options.model))
    if robot_kind == "sim" or tracker_kind == "sim":
        rig.sim_cell = SimCell.make(options.model, options.seed)
        rig.tracker_at_mm = SIM_TRACKER_AT_MM.copy()
    if options.tracker_at_mm is not None:
        rig.tracker_at_mm = np.asarray(options.tracker_at_mm, dtype=float)
    ROBOTS[robot_kind](robot_url, rig, options, stack)
    TRACKERS[tracker_kind](tracker_url, rig, options, stack)
    if rig.tracker_view is not None:
        rig.tracker = rig.tracker_view(rig.tracker)
    rig.tracker_id = tracker_url if tracker_kind != "sim" else "sim"
    stack.callback(rig.tracker.close)
    rig.tracker.connect()
    if rig.tracker.identity:
        rig.tracker_id = rig.tracker.identity
    stack.callback(_quiet_close, rig.robot)
    rig.robot.connect()
    return rig


def _quiet_close(robot) -> None:
    with contextlib.suppress(OSError):
        robot.close()
