"""A simulated arm behind the robot interface: no network, for the embedded default.

:class:`SimulatedRobot` is a "true" arm: its MDH table (usually a named model
plus hidden errors from :func:`calibrator.simulate.random_errors`), its base in the
tracker frame and its tool on the flange are what the real world would be.
It reports joint angles like an encoder (optionally with seeded noise) and
knows where its probe really is (:meth:`SimulatedRobot.true_tool_pose`), which
a listener receives after each completed move, so a tracker simulator can
measure it. Moves complete at once: there is no time in the simulation.

The dependency runs drivers -> calibrator (kinematics, models) only.
"""

import numpy as np

from calibrator.acquire import ports
from calibrator.kinematics import check_mdh, forward
from calibrator.models import get_model
from calibrator.simulate import random_errors
from drivers.robot.errors import EmergencyStop, NotReady, ProtectiveStop
from drivers.robot.interface import N_JOINTS, Robot, SafetyState, check_move_args


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
    """

    capabilities = frozenset({ports.REPORTS_TRUE_POSE})

    def __init__(
        self,
        true_mdh,
        base2tracker,
        flange2tool,
        *,
        initial_q=None,
        joint_noise_rad=0.0,
        rng=None,
        listener=None,
    ):
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
        self._encoder_error = np.zeros(N_JOINTS)
        self._connected = False
        self._protective = False
        self._emergency = False
        self._latched = False

    @classmethod
    def from_model(
        cls,
        name,
        rng,
        *,
        base2tracker=None,
        flange2tool=None,
        error_mm=0.5,
        error_rad=1e-3,
        **kwargs,
    ):
        """A true arm: the named model (``calibrator.models``) with hidden errors from ``rng``.

        The errors are :func:`calibrator.simulate.random_errors` (uniform
        within +-``error_mm`` and +-``error_rad`` on Hayati's parameter set).
        ``base2tracker`` and ``flange2tool`` default to identity; other keyword
        arguments go to the constructor.
        """
        nominal = get_model(name).mdh
        true_mdh = nominal + random_errors(nominal, rng, mm=error_mm, rad=error_rad)
        eye = np.eye(4)
        return cls(
            true_mdh,
            eye if base2tracker is None else base2tracker,
            eye if flange2tool is None else flange2tool,
            rng=rng,
            **kwargs,
        )

    # ------------------------------------------------------------ lifecycle
    def connect(self):
        self._connected = True

    def close(self):
        self._connected = False

    # --------------------------------------------------------------- state
    def actual_joints(self):
        self._check_connected()
        return self._q_true + self._encoder_error

    def safety_state(self):
        self._check_connected()
        return SafetyState(protective_stopped=self._protective, emergency_stopped=self._emergency)

    def true_tool_pose(self):
        """Where the probe really is: tool pose in the tracker frame, shape (4, 4), mm."""
        return forward(self._mdh, self._q_true[np.newaxis], self._flange2tool, self._base2tracker)[
            0
        ]

    # -------------------------------------------------------------- motion
    def move_joints(self, q_rad, speed_rad_s, accel_rad_s2):
        target = check_move_args(q_rad, speed_rad_s, accel_rad_s2)
        self._check_connected()
        if self._emergency:
            raise EmergencyStop("emergency stop engaged (simulated)")
        if self._protective or self._latched:
            raise ProtectiveStop("the arm was safety-stopped; call clear_protective_stop() first")
        self._q_true = target.copy()
        if self.joint_noise_rad > 0:
            self._encoder_error = self._rng.normal(0.0, self.joint_noise_rad, N_JOINTS)
        if self.listener is not None:
            self.listener(self.true_tool_pose())
        return self.actual_joints()

    def stop(self):
        self._check_connected()  # moves are instantaneous: nothing is ever in motion

    def clear_protective_stop(self):
        self._check_connected()
        if self._emergency:
            raise EmergencyStop("emergency stop engaged: release it first (simulated)")
        self._protective = False
        self._latched = False

    # ------------------------------------------------- simulation controls
    def inject_protective_stop(self):
        """Simulation control: the safety system trips (as a collision would)."""
        self._protective = self._latched = True

    def unlock_from_pendant(self):
        """Simulation control: an operator unlocks the protective stop on the pendant.

        The arm's safety flag clears, but this driver still refuses moves until
        :meth:`clear_protective_stop` is called, as the ``ur-rtde`` adapter does.
        """
        self._protective = False

    def inject_emergency_stop(self):
        """Simulation control: someone presses the e-stop."""
        self._emergency = self._latched = True

    def release_emergency_stop(self):
        """Simulation control: the operator releases the e-stop (a clear is still needed)."""
        self._emergency = False

    def _check_connected(self):
        if not self._connected:
            raise NotReady("simulated robot not connected; call connect() first")


def _check_transform(t, name):
    t = np.asarray(t, dtype=float)
    if t.shape != (4, 4):
        raise ValueError(f"{name} must have shape (4, 4), got {t.shape}")
    return t.copy()
