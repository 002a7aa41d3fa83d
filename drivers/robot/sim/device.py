"""A simulated arm behind the robot interface: no network, for the embedded default.

:class:`SimulatedRobot` is a "true" arm: its MDH table (usually a named model
plus hidden errors from :func:`calibrator.simulate.random_errors`), its base in the
tracker frame and its tool on the flange are what the real world would be.
It reports joint angles like an encoder (optionally with seeded noise) and
knows where its probe really is (:meth:`SimulatedRobot.true_tool_pose`), which
a listener receives after each completed move, so a tracker simulator can
measure it. Moves complete at once: there is no time in the simulation.

Opt-in repeatability (:class:`JointRepeatability`, off by default so every
existing simulated result is unchanged): after each move every joint lands
off its target by a fresh random positioning error (normal, per-joint
standard deviation) plus a direction-dependent backlash (half the lost
motion, against the direction the joint last moved in). Both sit on the load
side of the gears: the encoders report the target (plus the encoder noise
above), so the errors reach the probe but not the joint read-back, as on a
real arm. Approached always from the same side, the backlash is a constant
offset (it shifts AP); the random error spreads the attained poses (RP).

The dependency runs drivers -> calibrator (model, robots) only.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from calibrator import robots
from calibrator.acquire import ports
from calibrator.model import rotations
from calibrator.model.kinematics import check_mdh, forward
from calibrator.simulate import random_errors
from drivers.robot.errors import EmergencyStop, NotReady, ProtectiveStop
from drivers.robot.interface import N_JOINTS, Robot, SafetyState, check_move_args
from drivers.robot.options import RobotOptions


@dataclass(frozen=True)
class JointRepeatability:
    """The simulated arm's load-side joint errors (each a scalar or shape (6,)).

    Attributes
    ----------
    positioning_std_rad : float or array_like
        Standard deviation of the random positioning error of each joint, rad,
        drawn afresh on every move.
    backlash_rad : float or array_like
        Lost motion of each joint, rad: a joint that last moved in the
        positive direction stops ``backlash_rad / 2`` short of its target,
        one that last moved negative ``backlash_rad / 2`` beyond it.
    """

    positioning_std_rad: float | np.ndarray = 0.0
    backlash_rad: float | np.ndarray = 0.0

    @classmethod
    def typical(cls) -> JointRepeatability:
        """Values of a 10 kg-class collaborative arm (about 0.05 mm RP at 1 m reach).

        Positioning 8 urad (base, shoulder, elbow) and 15 urad (wrist);
        backlash 20 urad on every joint.
        """
        return cls(np.array([8, 8, 8, 15, 15, 15]) * 1e-6, np.full(N_JOINTS, 20e-6))

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """Both values as (6,) arrays, checked finite and >= 0."""
        out = []
        for name in ("positioning_std_rad", "backlash_rad"):
            value = np.broadcast_to(np.asarray(getattr(self, name), float), (N_JOINTS,))
            if not np.all(np.isfinite(value) & (value >= 0)):
                raise ValueError(f"{name} must be finite and >= 0, got {value}")
            out.append(value.copy())
        return out[0], out[1]


class SimulatedRobot(Robot):
    """The true arm of the simulation.

    Parameters
    ----------
    true_mdh : array_like, shape (6, 5)
        The arm's real MDH table (mm, rad), hidden from the identifier.
    base2tracker : array_like, shape (4, 4)
        Robot base frame in the tracker frame (mm).
    flange2tool : array_like, shape (4, 4)
        Probe (tool) frame in the flange frame (mm).
    initial_q : array_like, shape (6,), optional
        Starting joint angles, rad (default all zero).
    joint_noise_rad : float
        Standard deviation of the encoder error, rad: the joints reported after
        a move differ from the true ones by this noise (drawn once per move,
        so repeated reads at a pose agree, as an encoder's would).
    rng : numpy.random.Generator, optional
        Required when ``joint_noise_rad > 0``.
    listener : callable, optional
        Called as ``listener(tool_pose)`` with :meth:`true_tool_pose` (4x4, mm,
        tracker frame) after every completed move.
    repeatability : JointRepeatability, optional
        Load-side joint errors (default: none). Needs ``rng`` when not zero.
    """

    capabilities = frozenset({ports.REPORTS_TRUE_POSE})

    def __init__(
        self,
        true_mdh: ArrayLike,
        base2tracker: ArrayLike,
        flange2tool: ArrayLike,
        *,
        initial_q: ArrayLike | None = None,
        joint_noise_rad: float = 0.0,
        rng: np.random.Generator | None = None,
        listener: Callable[[np.ndarray], object] | None = None,
        repeatability: JointRepeatability | None = None,
    ) -> None:
        self._mdh = check_mdh(true_mdh).copy()
        if self._mdh.shape != (N_JOINTS, 5):
            raise ValueError(f"true_mdh must have shape (6, 5), got {self._mdh.shape}")
        self._base2tracker = _check_transform(base2tracker, "base2tracker")
        self._flange2tool = _check_transform(flange2tool, "flange2tool")
        if joint_noise_rad < 0:
            raise ValueError(f"joint_noise_rad must be >= 0, got {joint_noise_rad}")
        if joint_noise_rad > 0 and rng is None:
            raise ValueError("joint_noise_rad > 0 needs an explicit rng (numpy Generator)")
        self.joint_noise_rad = float(joint_noise_rad)
        self._rng = rng
        self.listener = listener
        q0 = np.zeros(N_JOINTS) if initial_q is None else np.asarray(initial_q, float)
        if q0.shape != (N_JOINTS,):
            raise ValueError(f"initial_q must have shape (6,), got {q0.shape}")
        self._q_true = q0.copy()
        self._q_target = q0.copy()
        self._encoder_error = np.zeros(N_JOINTS)
        self._position_std = np.zeros(N_JOINTS)
        self._backlash = np.zeros(N_JOINTS)
        self._direction = np.zeros(N_JOINTS)  # sign of each joint's last motion (0: none yet)
        if repeatability is not None:
            self.set_repeatability(repeatability, rng)
        self._connected = False
        self._control: Any = None  # a tracker simulator's control port (steer)
        self._protective = False
        self._emergency = False
        self._latched = False
        # The simulated tracker's ``run_path`` once the devices pair them (follow_path).
        self._run_path: Callable[..., int] | None = None

    @classmethod
    def from_model(
        cls,
        name: str,
        rng: np.random.Generator,
        *,
        base2tracker: ArrayLike | None = None,
        flange2tool: ArrayLike | None = None,
        error_mm: float = 0.5,
        error_rad: float = 1e-3,
        **kwargs: Any,
    ) -> SimulatedRobot:
        """A true arm: the named model (``calibrator.robots``) with hidden errors from ``rng``.

        The errors are :func:`calibrator.simulate.random_errors` (uniform
        within +-``error_mm`` and +-``error_rad`` on Hayati's parameter set).
        ``base2tracker`` and ``flange2tool`` default to identity; other keyword
        arguments go to the constructor.
        """
        nominal = robots.get(name).mdh
        true_mdh = nominal + random_errors(nominal, rng, mm=error_mm, rad=error_rad)
        eye = np.eye(4)
        return cls(
            true_mdh,
            eye if base2tracker is None else base2tracker,
            eye if flange2tool is None else flange2tool,
            rng=rng,
            **kwargs,
        )

    def set_repeatability(
        self, repeatability: JointRepeatability, rng: np.random.Generator | None = None
    ) -> None:
        """Switch on (or change) the load-side joint errors; see :class:`JointRepeatability`.

        Parameters
        ----------
        repeatability : JointRepeatability
        rng : numpy.random.Generator, optional
            Source of the positioning errors; required when they are not zero
            (it replaces the generator given to the constructor).
        """
        std, backlash = repeatability.arrays()
        if rng is not None:
            self._rng = rng
        if np.any(std > 0) and self._rng is None:
            raise ValueError("a random positioning error needs an explicit rng (numpy Generator)")
        self._position_std, self._backlash = std, backlash

    # ------------------------------------------------------------ lifecycle
    def connect(self) -> None:
        self._connected = True

    def close(self) -> None:
        self._connected = False
        control, self._control = self._control, None
        if control is not None:
            control.close()

    def steer(self, control_url: str) -> None:
        """After each move, tell a tracker simulator started by hand where the probe is.

        ``control_url``: the simulator's control port (``socket://127.0.0.1:PORT``);
        the probe's true pose goes there as ``SIM,TARGET`` (tracker frame, mm and
        rad). Closed with the robot.

        Raises
        ------
        ValueError
            The control port cannot be opened.
        """
        from drivers.tracker.line.simulator.launch import SimulatorControl

        try:
            control = SimulatorControl(control_url)
        except (OSError, ValueError) as exc:
            raise ValueError(f"control={control_url}: {exc}") from None
        self._control = control
        self.listener = lambda pose: control.set_target(
            pose[:3, 3], rotations.matrix_to_rotvec(pose[:3, :3])
        )

    # --------------------------------------------------------------- state
    def actual_joints(self) -> np.ndarray:
        self._check_connected()
        # The encoders sit before the gears: they see the target, not the load-side errors.
        return self._q_target + self._encoder_error

    def safety_state(self) -> SafetyState:
        self._check_connected()
        return SafetyState(protective_stopped=self._protective, emergency_stopped=self._emergency)

    def true_tool_pose(self) -> np.ndarray:
        """Where the probe really is: tool pose in the tracker frame, shape (4, 4), mm."""
        return forward(self._mdh, self._q_true[np.newaxis], self._flange2tool, self._base2tracker)[
            0
        ]

    # -------------------------------------------------------------- motion
    def move_joints(self, q_rad: ArrayLike, speed_rad_s: float, accel_rad_s2: float) -> np.ndarray:
        target = check_move_args(q_rad, speed_rad_s, accel_rad_s2)
        self._check_connected()
        if self._emergency:
            raise EmergencyStop("emergency stop engaged (simulated)")
        if self._protective or self._latched:
            raise ProtectiveStop("the arm was safety-stopped; call clear_protective_stop() first")
        moved = np.sign(target - self._q_target)
        self._direction = np.where(moved != 0, moved, self._direction)
        self._q_target = target.copy()
        self._q_true = target.copy()
        # The constructor and set_repeatability refuse noise without a generator.
        if self.joint_noise_rad > 0 and self._rng is not None:
            self._encoder_error = self._rng.normal(0.0, self.joint_noise_rad, N_JOINTS)
        if np.any(self._backlash > 0):
            self._q_true -= 0.5 * self._backlash * self._direction
        if np.any(self._position_std > 0) and self._rng is not None:
            self._q_true += self._rng.normal(0.0, 1.0, N_JOINTS) * self._position_std
        if self.listener is not None:
            self.listener(self.true_tool_pose())
        return self.actual_joints()

    def runs_path_on(self, run_path: Callable[..., int]) -> None:
        """Offer :data:`~calibrator.acquire.ports.FOLLOW_PATH` on a tracker simulator's path.

        ``run_path(t_s, point_mm, delay_s=..., rotvec_rad=...)``: the simulated
        tracker's (:class:`~calibrator.acquire.ports.RunsPath`), which moves its
        target through the probe's true poses and returns the start on its clock, us.
        """
        self._run_path = run_path
        self.capabilities = self.capabilities | {ports.FOLLOW_PATH}

    def follow_path(self, t_s: ArrayLike, q_rad: ArrayLike, delay_s: float = 0.0) -> int:
        """Run the joint path: the true arm's probe at each command goes to the tracker.

        Parameters
        ----------
        t_s : array_like, shape (N,)
            Command times from the start of the motion, s.
        q_rad : array_like, shape (N, 6)
            Joint commands, rad. The arm follows them exactly (kinematic: no
            servo lag, no repeatability scatter on a path).
        delay_s : float
            Hold at the first command this long first, s.

        Returns
        -------
        int
            The start of the motion on the tracker's clock, microseconds.

        Raises
        ------
        ValueError
            No tracker simulator to run the path on (:meth:`runs_path_on`).
        """
        if self._run_path is None:
            raise ValueError("the simulated arm follows a path only with the simulated tracker")
        q = np.asarray(q_rad, dtype=float)
        true = forward(self._mdh, q, self._flange2tool, self._base2tracker)
        # The probe's orientations too (a 6-DoF probe streams them), as a continuous
        # sequence: the simulator interpolates them linearly between waypoints.
        rotvec = continuous_rotvecs(rotations.matrix_to_rotvec(true[:, :3, :3]))
        return self._run_path(
            np.asarray(t_s, dtype=float), true[:, :3, 3], delay_s=delay_s, rotvec_rad=rotvec
        )

    def stop(self) -> None:
        self._check_connected()  # moves are instantaneous: nothing is ever in motion

    def clear_protective_stop(self) -> None:
        self._check_connected()
        if self._emergency:
            raise EmergencyStop("emergency stop engaged: release it first (simulated)")
        self._protective = False
        self._latched = False

    # ------------------------------------------------- simulation controls
    def inject_protective_stop(self) -> None:
        """Simulation control: the safety system trips (as a collision would)."""
        self._protective = self._latched = True

    def unlock_from_pendant(self) -> None:
        """Simulation control: an operator unlocks the protective stop on the pendant.

        The arm's safety flag clears, but this driver still refuses moves until
        :meth:`clear_protective_stop` is called, as the ``ur-rtde`` adapter does.
        """
        self._protective = False

    def inject_emergency_stop(self) -> None:
        """Simulation control: someone presses the e-stop."""
        self._emergency = self._latched = True

    def release_emergency_stop(self) -> None:
        """Simulation control: the operator releases the e-stop (a clear is still needed)."""
        self._emergency = False

    def _check_connected(self) -> None:
        if not self._connected:
            raise NotReady("simulated robot not connected; call connect() first")


def _check_transform(t: ArrayLike, name: str) -> np.ndarray:
    t = np.asarray(t, dtype=float)
    if t.shape != (4, 4):
        raise ValueError(f"{name} must have shape (4, 4), got {t.shape}")
    return t.copy()


#: What ``sim://?...`` takes: ``repeatability=typical`` gives the arm a typical
#: arm's joint positioning error and backlash (:meth:`JointRepeatability.typical`),
#: ``none`` lands it exactly; left out, the world's own (``SimWorld.repeatability``).
#: ``control``: the control URL of a tracker simulator started by hand, which the
#: arm steers (:meth:`SimulatedRobot.steer`).
URL_PARAMS: dict = {"repeatability": ("typical", "none"), "control": None}


def open_url(url: str, options: RobotOptions) -> SimulatedRobot:
    """The robot registry's handler of ``sim`` and ``sim://?repeatability=typical|none&control=URL``.

    The true arm, base and tool are those of ``options.world`` (required).

    Raises
    ------
    ValueError
        No world, or a malformed URL.
    """
    from drivers import urls

    params = urls.settings(url, "sim", URL_PARAMS)
    world = options.world
    if world is None:
        raise ValueError("--robot sim needs the simulated world (measure builds it)")
    chosen = params.get("repeatability")
    repeatability = (
        world.repeatability
        if chosen is None
        else (JointRepeatability.typical() if chosen == "typical" else None)
    )
    robot = SimulatedRobot(
        world.true_mdh,
        world.base2tracker,
        world.flange2tool,
        repeatability=repeatability,
        rng=world.repeatability_rng() if repeatability is not None else None,
    )
    robot.device_id = f"sim:{world.model.name}:seed={world.seed}"
    if "control" in params:
        robot.steer(params["control"])
    return robot


def continuous_rotvecs(rotvec_rad: np.ndarray) -> np.ndarray:
    """Rotation vectors (N, 3), rad, with no jump between neighbours: the same rotations.

    :func:`calibrator.model.rotations.matrix_to_rotvec` keeps angles in
    [0, pi], so an orientation turning through pi flips its vector to the
    other side (``r`` and ``r (1 - 2 pi / |r|)`` are one rotation); a linear
    interpolation across that flip would pass through unrelated rotations.
    Each vector that lies farther from its predecessor than its other form
    does is flipped, and every later one with it (the parity of the flips).
    """
    r = np.asarray(rotvec_rad, dtype=float)
    angle = np.linalg.norm(r, axis=1, keepdims=True)
    other = r * (1.0 - 2.0 * np.pi / np.where(angle > 0, angle, 1.0))
    other = np.where(angle > 0, other, r)
    jump = np.linalg.norm(r[1:] - r[:-1], axis=1) > np.linalg.norm(other[1:] - r[:-1], axis=1)
    odd = np.concatenate([[False], np.cumsum(jump) % 2 == 1])
    return np.where(odd[:, None], other, r)
