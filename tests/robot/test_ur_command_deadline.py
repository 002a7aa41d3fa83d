"""A control command the controller never answers is abandoned at its deadline.

The ur-rtde client waits up to its own 300 s for the control script's answer
on a link that went silent with its sockets open. The adapter runs each
command in a daemon thread and gives up after ``command_timeout_s``: the link
is then lost, and the abandoned call can never keep the process from exiting.
"""

import threading
import time

import numpy as np
import pytest

from drivers.errors import ConnectionLost
from drivers.robot.ur_rtde_adapter import UrRtdeRobot

pytest.importorskip("rtde_control")

COMMAND_S = 0.5


def test_a_command_without_an_answer_is_abandoned_in_a_daemon_thread(fake_ur):
    # The stale-data bound (10 s) is far away, so only the command's deadline can end it.
    robot = UrRtdeRobot("127.0.0.1", stale_after_s=10.0, command_timeout_s=COMMAND_S)
    with robot:
        start = robot.actual_joints()
        assert fake_ur.command("fake stall") == "fake: stalled"
        t0 = time.monotonic()
        with pytest.raises(ConnectionLost) as info:
            robot.move_joints(start + np.array([0, 0, 0, 0, 0, 0.5]), 0.5, 1.0)
        elapsed = time.monotonic() - t0
        assert str(info.value) == (
            f"UR controller at 127.0.0.1: command moveJ got no answer in {COMMAND_S} s"
        )
        assert COMMAND_S - 0.05 <= elapsed < COMMAND_S + 2.0, elapsed
        abandoned = [t for t in threading.enumerate() if t.name == "ur-rtde command"]
        assert abandoned and all(t.daemon for t in abandoned)
        # Every later call refuses, naming what was lost.
        with pytest.raises(ConnectionLost, match="moveJ got no answer"):
            robot.actual_joints()
