"""The robot and tracker of one cell procedure, opened by URL.

:class:`Devices` is the drivers' side of the port
:class:`calibrator.acquire.ports.Devices`: it opens ``--robot`` and
``--tracker`` through the registries (:func:`drivers.robot.open_robot`,
:func:`drivers.tracker.open_tracker`), the simulated cell like any other
devices, its settings in its URLs (``sim://?noise=off``) and its true arm in
a world file::

    from drivers.devices import Devices

    Devices()                                      # the simulated cell, seeded by the run
    Devices("sim://?repeatability=typical", "sim://?noise=off&probe=6dof")
    Devices("sim://?control=socket://127.0.0.1:PORT", "/dev/pts/4")  # a simulator by hand
    Devices("ur://10.0.0.5", "emscon://10.0.0.7")  # a real cell

The simulated tracker takes ``noise=on|off``, ``probe=3dof|6dof``,
``faults=PATH``, ``replay=PATH``, ``record=PATH`` and ``latency=S`` (its
stamps S seconds late for a moving target; ``emscon+sim``, the same simulated
tracker behind a Leica emScon server, takes the first three); the simulated robot
``repeatability=typical|none`` and ``control=URL`` (it steers a tracker
simulator started by hand); the world file (:mod:`calibrator.world`) the true
arm both move. When the tracker is simulated its target follows the arm's
true probe after each move (:mod:`drivers.robot.sim.follow`), and along the
timed paths a UR runs (:mod:`drivers.robot.ur.sim_cell`): the simulated
world stays behind the devices, and a procedure gets of it only plain data
(:class:`~calibrator.acquire.ports.Opened`: where the tracker stands, the
base frame as surveyed).
"""

from __future__ import annotations

from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from calibrator.acquire.ports import STEER, Opened
from calibrator.errors import CalibrationError
from drivers.registry import scheme
from drivers.robot.sim.follow import steer_tracker
from drivers.robot.ur.sim_cell import follow_paths

#: The simulated devices' kinds: ``sim`` (robot; tracker in the line protocol) and
#: ``emscon+sim`` (the tracker behind an emScon server).
SIM_KINDS = frozenset({"sim", "emscon+sim"})


def is_sim(url: str) -> bool:
    """``url`` names a simulated device: ``sim`` or ``emscon+sim``, bare or with its
    settings (``sim://?...``)."""
    return scheme(url) in SIM_KINDS


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
        Log the tracker's raw exchange there (line-protocol kinds); for the
        simulated tracker also ``sim://?record=PATH``.
    max_speed_rad_s : float, optional
        Lower the arm's speed cap (never raise it).
    external : calibrator.acquire.external.arm.ExternalOptions, optional
        Stop detection and association of the ``external`` robot.
    """

    robot: str = "sim"
    tracker: str = "sim"
    world: Any = None
    record: Path | None = None
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
            A URL no kind opens.
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
        tracker_url, record = recorded(self.tracker)
        try:
            tracker = open_tracker(
                tracker_url,
                OpenOptions(
                    record=record if record is not None else self.record,
                    world=world if is_sim(self.tracker) else None,
                ),
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
        if world is None:
            return Opened(robot, tracker)
        if STEER.offered_by(tracker):
            # The simulated pair: the simulated tracker's target follows the true
            # probe of whatever arm moves (the simulated arm says where it is; any
            # other arm's reported joints are put through the world's true arm).
            robot = steer_tracker(robot, tracker, world.tool_pose)
            # and the fake UR's timed paths too (the path test: drivers.robot.ur.sim_cell)
            robot = follow_paths(robot, tracker, world.tool_pose)
        # What a procedure may know of the simulated cell, as plain data.
        return Opened(
            robot,
            tracker,
            tracker_at_mm=np.array(world.tracker_at_mm, dtype=float),
            surveyed_base2tracker=world.surveyed_base2tracker(),
        )


def sim_settings(url: str) -> dict[str, str]:
    """The settings of a simulated device's URL (``sim://?noise=off`` -> ``{"noise": "off"}``)."""
    from urllib.parse import parse_qsl, urlsplit

    if not is_sim(url) or "://" not in url:
        return {}
    return dict(parse_qsl(urlsplit(url).query, keep_blank_values=True))


def recorded(url: str) -> tuple[str, Path | None]:
    """A simulated tracker's URL without its ``record=PATH``, and that path (else None).

    The rest of the URL is kept as written (the simulator reads its own settings).
    """
    path = sim_settings(url).get("record")
    if path is None:
        return url, None
    head, _, query = url.partition("?")
    kept = [part for part in query.split("&") if part.partition("=")[0] != "record"]
    return head + ("?" + "&".join(kept) if kept else ""), Path(path)
