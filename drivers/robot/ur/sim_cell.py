"""The fake UR in the simulated cell: the simulated tracker sees the paths it runs.

``measure --robot ur://127.0.0.1 --tracker sim`` pairs the fake controller
with the simulated world through :class:`~drivers.robot.sim.follow.Following`:
after each move the world's true arm at the joints the controller reports
places the tracker's target. A path test needs the target to *move* while the
tracker streams: :class:`PathFollowing` gives the tracker simulator the true
arm's probe along the path's joint commands as a timed path (``SIM,PATH``)
that starts when the UR starts the motion, through the host's clock:

1. the arm moves to the path's first command (a move the tracker follows);
2. a short stream of the tracker (:data:`CLOCK_TICKS` ticks) maps its clock
   onto the host's: the smallest gap between a tick's arrival and its stamp,
   as the path test maps its stream (:func:`tracker_clock_offset`);
3. the tracker simulator gets the true probe's points and starts them
   ``delay_s`` after it received ``GO`` (its reply carries that start on its
   clock);
4. the UR starts its motion at that start on the host's clock (a reply
   read late on a loaded host does not delay it).

The tracker thus sees the true arm along the commanded joints on the
commanded timing, plus its own latency (``sim://?latency=S``); the fake
arm's actual joints (what the UR's joint stream reports) follow the servoJ
commands a few milliseconds late, which the path test reports as the arm's
start (``start_s``). Poses: tool in the tracker frame, (4, 4), mm.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from calibrator.acquire import ports
from drivers.robot.sim.follow import Following
from drivers.robot.ur.device import GuardedUr, UrRtdeRobot, lead_in_motion

#: Ticks (at :data:`CLOCK_HZ`) of the stream that maps the tracker's clock onto the host's.
CLOCK_TICKS = 100
CLOCK_HZ = 500


def tracker_clock_offset(tracker: Any, ticks: int = CLOCK_TICKS) -> float:
    """Host monotonic time less the tracker's clock, s: the smallest gap seen over a stream.

    A tick is sent once its stamp is due, so each arrival is its stamp plus
    the offset plus a delay; the smallest of ``ticks`` is the offset within
    the link's least delay.
    """
    gaps = []
    with tracker.stream(CLOCK_HZ, count=ticks, stall_timeout_s=5.0) as stream:
        for sample in stream:
            gaps.append(time.monotonic() - sample.device_time_us / 1e6)
    if not gaps:
        raise ValueError("the tracker streamed no tick to map its clock by")
    return min(gaps)


def follow_paths(robot: Any, tracker: Any, tool_pose: Callable[[Any], Any]) -> Any:
    """``robot`` made to run its paths on ``tracker``'s target, when both can.

    Parameters
    ----------
    robot : Any
        The robot the devices opened, already following moves
        (:func:`drivers.robot.sim.follow.steer_tracker`).
    tracker : Any
        The simulated tracker (:class:`~calibrator.acquire.ports.RunsPath`).
    tool_pose : callable
        ``tool_pose(q_rad)``: the world's true probe pose (4, 4), mm, tracker
        frame, for joints (6,), rad.

    Returns
    -------
    ``robot`` itself, or wrapped in :class:`PathFollowing` (a UR: the fake
    controller's; its paths start at a moment of the host's clock).
    """
    if (
        isinstance(robot, Following)
        and isinstance(robot.robot, (GuardedUr, UrRtdeRobot))  # the start is the host's
        and ports.FOLLOW_PATH.offered_by(robot.robot)
        and isinstance(tracker, ports.RunsPath)
    ):
        return PathFollowing(robot, tracker, tool_pose)
    return robot


class PathFollowing(Following):
    """A :class:`Following` robot whose timed paths the simulated tracker's target runs.

    Parameters
    ----------
    robot : drivers.robot.sim.follow.Following
        The robot whose moves the tracker already follows.
    tracker : calibrator.acquire.ports.RunsPath
    tool_pose : callable
        As :func:`follow_paths`.
    """

    def __init__(
        self, robot: Following, tracker: ports.RunsPath, tool_pose: Callable[[Any], Any]
    ) -> None:
        super().__init__(robot, lambda q: None)  # the inner one steers after moves
        self.tracker = tracker
        self.tool_pose = tool_pose

    def follow_path(self, t_s: ArrayLike, q_rad: ArrayLike, delay_s: float = 0.0) -> int:
        """Run the path on the robot and the true probe's path on the tracker, together.

        Returns
        -------
        int
            The start of the motion on the tracker's clock, microseconds.
        """
        t = np.asarray(t_s, dtype=float)
        q = np.asarray(q_rad, dtype=float)
        if q.ndim != 2 or len(q) != len(t) or len(t) < 2:
            raise ValueError(f"a path is t_s (N >= 2,) and q_rad (N, 6), got {t.shape}, {q.shape}")
        # Within the caps of the guard the UR is opened behind (a user's --max-speed).
        self.robot.move_joints(q[0], *lead_in_motion(getattr(self.robot, "limits", None)))
        points = np.array([np.asarray(self.tool_pose(qi), float)[:3, 3] for qi in q])
        offset = tracker_clock_offset(self.tracker)
        start_us = self.tracker.run_path(t, points, delay_s=delay_s)
        self.robot.follow_path(t, q, delay_s=delay_s, start_host_s=start_us / 1e6 + offset)
        return start_us
