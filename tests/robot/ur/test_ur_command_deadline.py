"""A control command the controller never answers is abandoned at its deadline.

The ur-rtde client waits up to its own 300 s for the control script's answer
on a link that went silent with its sockets open. The adapter runs each
command in a daemon thread and gives up after ``command_timeout_s``: the link
is then lost, and the abandoned call can never keep the process from exiting.

About one run in twenty, the client takes the move as started from the
last packet it read before the silence (seen on the fake: ``moveJ``
returned True within the deadline). The adapter then waits for the move
and loses the link when the client's own watchdog closes it, 2.5 s into
the silence. Either way the move fails with :class:`ConnectionLost` in
bounded time; the deadline's own path is run again until it is the one
taken.
"""

import threading
import time

import numpy as np
import pytest

from drivers.errors import ConnectionLost
from drivers.robot.ur.device import UrRtdeRobot

pytest.importorskip("rtde_control")

COMMAND_S = 0.5
WATCHDOG_S = 2.5  # the ur-rtde client's own bound on a silent stream (measured)
NO_ANSWER = f"UR controller at 127.0.0.1: command moveJ got no answer in {COMMAND_S} s"


def _move_into_silence(fake):
    """Stall the fake, then move: (error message, seconds to it, abandoned threads, later error)."""
    # The stale-data bound (10 s) is far away, so only the deadline or the link can end it.
    robot = UrRtdeRobot("127.0.0.1", stale_after_s=10.0, command_timeout_s=COMMAND_S)
    with robot:
        start = robot.actual_joints()
        assert fake.command("fake stall") == "fake: stalled"
        t0 = time.monotonic()
        with pytest.raises(ConnectionLost) as info:
            robot.move_joints(start + np.array([0, 0, 0, 0, 0, 0.5]), 0.5, 1.0)
        elapsed = time.monotonic() - t0
        abandoned = [t for t in threading.enumerate() if t.name == "ur-rtde command"]
        with pytest.raises(ConnectionLost) as later:
            robot.actual_joints()
    return str(info.value), elapsed, abandoned, str(later.value)


def test_a_command_without_an_answer_is_abandoned_in_a_daemon_thread(fake_manager):
    for _ in range(4):
        message, elapsed, abandoned, later = _move_into_silence(fake_manager.running())
        if message == NO_ANSWER:
            break
        # The client took the move as started: the link is lost by its watchdog.
        assert message == "lost the RTDE connection to 127.0.0.1", message
        assert WATCHDOG_S - 0.1 <= elapsed < WATCHDOG_S + 2.0, elapsed
        assert "RTDE connection closed" in later
    assert message == NO_ANSWER
    assert COMMAND_S - 0.05 <= elapsed < COMMAND_S + 2.0, elapsed
    assert abandoned and all(t.daemon for t in abandoned)
    # Every later call refuses, naming what was lost.
    assert "moveJ got no answer" in later
