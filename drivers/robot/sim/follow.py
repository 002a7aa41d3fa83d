"""The simulated cell's pairing: the simulated tracker's target follows the arm's true probe.

When the tracker is simulated, something must tell it where the probe
really is after each move. :func:`steer_tracker` wires that behind the
devices, so a procedure never sees the simulated world:

- the simulated arm (:class:`~drivers.robot.sim.device.SimulatedRobot`) knows
  its true probe pose and hands it to the tracker after each move (its
  ``listener``);
- the simulated arm also runs a timed joint path (``follow_path``, the path
  tests) as the tracker simulator's target path, the true probe's points;
- any other arm (the fake UR of ``ur://127.0.0.1``, which moves the nominal
  arm only) is wrapped in :class:`Following`: after each move the world's
  true arm at the joints the arm reports gives the probe's pose.

Poses are the tool in the tracker frame, (4, 4), mm; the tracker is told its
point (mm) and the probe's orientation (rotation vector, rad).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from calibrator.acquire import ports
from calibrator.model import rotations
from drivers.robot.interface import Robot
from drivers.robot.sim.device import SimulatedRobot


def steer_tracker(robot: Any, tracker: ports.Steerable, tool_pose: Callable[[Any], Any]) -> Any:
    """``robot``, made to move ``tracker``'s target to the true probe after each move.

    Parameters
    ----------
    robot : drivers.robot.interface.Robot
        The arm; a simulated one (:data:`~calibrator.acquire.ports.REPORTS_TRUE_POSE`)
        reports its own true pose, any other is wrapped in :class:`Following`.
    tracker : calibrator.acquire.ports.Steerable
        The simulated tracker (``set_target``).
    tool_pose : callable
        ``tool_pose(q_rad)``: the world's true probe pose (4, 4), mm, tracker
        frame, for joints (6,), rad.

    Returns
    -------
    The robot to run: ``robot`` itself, or ``robot`` wrapped.
    """

    def steer(pose: np.ndarray) -> None:
        # The orientation too: a 6-DoF probe reports it (a plain reflector ignores it).
        tracker.set_target(pose[:3, 3], rotations.matrix_to_rotvec(pose[:3, :3]))

    if ports.REPORTS_TRUE_POSE.offered_by(robot):
        robot.listener = steer
        if isinstance(robot, SimulatedRobot) and isinstance(tracker, ports.RunsPath):
            # A timed path too (the path tests): the tracker's target runs the true
            # probe's points while it streams them.
            robot.runs_path_on(tracker.run_path)
        return robot
    return Following(robot, lambda q: steer(np.asarray(tool_pose(q), float)))


class Following(Robot):
    """Any robot, calling ``after_move(actual_q_rad)`` after each completed move.

    Everything else is the inner robot's: its capabilities, its identity and
    any method beyond the contract (``check_plan``, ``joint_temperatures``).

    Parameters
    ----------
    robot : drivers.robot.interface.Robot
    after_move : callable
        Called with the joints the move returned, shape (6,), rad.
    """

    def __init__(self, robot: Any, after_move: Callable[[np.ndarray], None]) -> None:
        self.robot = robot
        self.after_move = after_move
        self.capabilities = frozenset(robot.capabilities)
        # Drivers name themselves when opened (``open_robot``), never later.
        self.device_id = str(getattr(robot, "device_id", "") or type(robot).__name__)

    def __getattr__(self, name: str) -> Any:
        # Only reached for names this class lacks: the inner robot's extras.
        if name == "robot":
            raise AttributeError(name)
        return getattr(self.robot, name)

    def move_joints(self, q_rad: ArrayLike, speed_rad_s: float, accel_rad_s2: float) -> np.ndarray:
        actual = self.robot.move_joints(q_rad, speed_rad_s, accel_rad_s2)
        self.after_move(np.asarray(actual, dtype=float))
        return actual

    def connect(self) -> object:
        return self.robot.connect()

    def close(self) -> None:
        self.robot.close()

    def actual_joints(self) -> np.ndarray:
        return self.robot.actual_joints()

    def safety_state(self) -> object:
        return self.robot.safety_state()

    def stop(self) -> None:
        self.robot.stop()

    def clear_protective_stop(self) -> None:
        self.robot.clear_protective_stop()
