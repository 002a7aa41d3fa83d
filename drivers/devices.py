"""The robot and tracker of one cell procedure, opened by URL.

:class:`Devices` is the drivers' side of the port
:class:`calibrator.acquire.ports.Devices`: it opens ``--robot`` and
``--tracker`` through the registries (:func:`drivers.robot.open_robot`,
:func:`drivers.tracker.open_tracker`), the simulated cell like any other
devices, its settings in its URLs (``sim://?noise=off``) and its true arm in
a world file::

    from drivers.devices import Devices

    Devices()                                      # the simulated cell, seeded by the run
    Devices("ur://10.0.0.5", "emscon://10.0.0.7")  # a real cell
"""

from __future__ import annotations

from collections.abc import Callable
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from calibrator.acquire.ports import Opened
from calibrator.errors import CalibrationError
from drivers.registry import scheme


def is_sim(url: str) -> bool:
    """``url`` names the simulated device: ``sim``, or ``sim://?...`` with its settings."""
    return scheme(url) == "sim"


@dataclass(frozen=True)
class Devices:
    """A robot URL and a tracker URL, and how to open them.

    Attributes
    ----------
    robot, tracker : str
        ``sim`` (or ``sim://?settings``), ``ur://HOST``, ``external``; ``sim``,
        a device path, ``socket://``, ``emscon://`` (``drivers.tracker``).
    world : calibrator.world.World, optional
        A world file's true arm for the simulated cell (default: the arm
        drawn from the run's seed).
    record : Path, optional
        Log the tracker's raw exchange there (line-protocol kinds).
    sim_control : str, optional
        Control URL of a tracker simulator started by hand, which the simulated
        robot steers.
    max_speed_rad_s : float, optional
        Lower the arm's speed cap (never raise it).
    external : calibrator.acquire.external.arm.ExternalOptions, optional
        Stop detection and association of the ``external`` robot.
    """

    robot: str = "sim"
    tracker: str = "sim"
    world: Any = None
    record: Path | None = None
    sim_control: str | None = None
    max_speed_rad_s: float | None = None
    external: Any = None

    @property
    def tracker_url(self) -> str:
        return self.tracker

    @property
    def simulated(self) -> bool:
        """Either device is simulated: the run has a simulated world."""
        return is_sim(self.robot) or is_sim(self.tracker)

    def sim_world(self, arm: Any, seed: int) -> Any:
        """The simulated cell's truth for ``arm`` and ``seed`` (the world file's, if given)."""
        from calibrator.simulate import SimWorld

        if self.world is not None:
            return self.world.build(arm.name, seed)
        return SimWorld.make(arm.name, seed)

    def tracker_at_mm(self, arm: Any, seed: int) -> tuple[float, float, float] | None:
        """Where the simulated cell's tracker stands (robot base frame, mm); None on hardware."""
        if not self.simulated:
            return None
        from calibrator.simulate import SimWorld

        x, y, z = (float(v) for v in SimWorld.make(arm.name, seed).tracker_at_mm)
        return x, y, z

    def open(self, arm: Any, seed: int, place_tracker_at: Any, stack: ExitStack) -> Opened:
        """Both devices, unconnected (see :meth:`calibrator.acquire.ports.Devices.open`).

        Raises
        ------
        CalibrationError
            A URL no kind opens, or ``sim_control`` without a simulated robot.
        """
        from drivers.robot import RobotOptions, open_robot
        from drivers.tracker import OpenOptions, open_tracker

        world = None
        if self.simulated:
            # The arm's repeatability is the simulated robot's setting (its URL).
            world = self.sim_world(arm, seed)
            if place_tracker_at is not None:
                # The simulated tracker stands where the user (or the cell file) says.
                world = world.with_tracker_at(place_tracker_at)
        try:
            tracker = open_tracker(
                self.tracker,
                OpenOptions(record=self.record, world=world if is_sim(self.tracker) else None),
            )
        except ValueError as exc:
            raise CalibrationError(f"--tracker: {exc}") from None
        robot_options = RobotOptions(
            arm, world, max_speed_rad_s=self.max_speed_rad_s, external=self.external
        )
        try:
            robot = open_robot(self.robot, robot_options)
        except ValueError as exc:
            raise CalibrationError(f"--robot: {exc}") from None
        steer = None
        if self.sim_control is not None:
            steer = _sim_control(self.sim_control, robot, stack)
        return Opened(robot, tracker, world, steer)


def _sim_control(
    url: str, robot: Any, stack: ExitStack
) -> Callable[[np.ndarray, np.ndarray], None]:
    """The simulated robot steers a tracker simulator started by hand (its control URL)."""
    from calibrator.acquire.ports import REPORTS_TRUE_POSE
    from drivers.tracker.line.simulator.launch import SimulatorControl

    if REPORTS_TRUE_POSE not in robot.capabilities:
        raise CalibrationError(
            "--sim-control needs --robot sim (the simulated arm says where its probe is)"
        )
    try:
        control = SimulatorControl(url)
    except (OSError, ValueError) as exc:
        raise CalibrationError(f"--sim-control {url}: {exc}") from None
    stack.callback(control.close)
    return control.set_target
