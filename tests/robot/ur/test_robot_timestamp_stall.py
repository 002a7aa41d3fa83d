"""A controller that keeps streaming but repeats one RTDE timestamp is a lost link.

The ur-rtde client notices a controller that goes silent by itself; it does
not notice one that keeps its sockets open and repeats the same packet. Only
the adapter's stale-timestamp check does, and it must do so within its bound.
"""

import time

import numpy as np
import pytest

from drivers.errors import ConnectionLost
from drivers.robot.ur.device import UrRtdeRobot

pytest.importorskip("rtde_receive")

HOST = "127.0.0.1"
STALE_S = 0.5
# The client's receive thread may show the frozen packet a little late on a
# loaded machine; 3 x STALE_S would still fail the bound.
SLACK_S = 0.75


def test_repeated_timestamp_during_a_move_is_connection_lost_within_the_stale_bound(fake_ur):
    robot = UrRtdeRobot(HOST, stale_after_s=STALE_S)
    with robot:
        start = robot.actual_joints()
        assert fake_ur.command("fake freeze timestamp") == "fake: timestamp frozen"
        frozen_at = time.monotonic()
        # A 20 s move: without the stale check it would run to its deadline.
        with pytest.raises(ConnectionLost, match="no RTDE data"):
            robot.move_joints(start + np.array([0, 0, 0, 0, 0, 2.0]), 0.1, 1.0)
        elapsed = time.monotonic() - frozen_at
        # The link counts as lost after STALE_S without a new timestamp, not before.
        assert STALE_S - 0.05 <= elapsed <= STALE_S + SLACK_S, elapsed
        assert "timestamp_frozen" in fake_ur.command("fake status")
        with pytest.raises(ConnectionLost):
            robot.actual_joints()


def test_repeated_timestamp_while_idle_is_noticed_by_polling(fake_ur):
    robot = UrRtdeRobot(HOST, stale_after_s=STALE_S)
    with robot:
        robot.actual_joints()
        fake_ur.command("fake freeze timestamp")
        frozen_at = time.monotonic()
        with pytest.raises(ConnectionLost, match="no RTDE data"):
            while time.monotonic() - frozen_at < STALE_S + 3.0:
                robot.actual_joints()
                time.sleep(0.02)
        elapsed = time.monotonic() - frozen_at
        assert STALE_S - 0.05 <= elapsed <= STALE_S + SLACK_S, elapsed
