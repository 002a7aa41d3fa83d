"""Clearing a safety stop restarts the control script even while the client still shows it running.

A safety stop ends the controller's program. The ``ur-rtde`` control
interface learns that from its own RTDE stream, which a loaded host reads
late: for a while ``isProgramRunning()`` still says the old program runs.
Trusting that view, ``clear_protective_stop`` skipped the restart, and the
next move failed with "RTDE control script is not running!" (seen twice on
a loaded machine). The fake controller's ``program lag`` makes its stream
show the program's start and end late, as such a host does.

The adapter then waits for that view to show the end before restarting.
These tests cannot tell that wait from ur-rtde 1.6.5's own: its
``reuploadScript``, seeing a script run, first sends that script a stop
command, which waits until the view shows it ended. The adapter does not
rely on a command sent to a dead script.
"""

import time

import numpy as np
import pytest
from robot_kit import wait_until

pytest.importorskip("rtde_control")

LAG_S = 0.5  # the stream shows the program's end this late
TOL = 1e-3


def assert_seen_running_throughout(robot, seconds):
    """The client sees a script running at every poll for ``seconds``.

    A restart sent while its view still showed the ended script would show
    that end late, mid-way: a move sent then fails.
    """
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        assert robot._control.isProgramRunning(), "the client saw the script end after clearing"
        time.sleep(0.005)


def assert_cleared_and_moving(robot, fake, start):
    """The script runs on the controller, the client sees it so throughout, and a move runs."""
    assert fake.command("programstate").startswith("PLAYING")
    assert_seen_running_throughout(robot, LAG_S + 0.3)
    target = start + np.array([0.0, 0.0, 0.05, 0.0, 0.0, 0.0])
    np.testing.assert_allclose(robot.move_joints(target, 1.0, 2.0), target, atol=TOL)


def test_a_move_right_after_clearing_a_protective_stop_runs(ur_robot, fake_ur):
    assert fake_ur.command(f"fake program lag {LAG_S:g}") == f"fake: program lag {LAG_S:g}"
    start = ur_robot.actual_joints()
    assert fake_ur.command("fake protective stop") == "fake: protective stop"
    wait_until(lambda: ur_robot.safety_state().protective_stopped, what="the stop on the stream")
    assert ur_robot._control.isProgramRunning()  # the client's view: the old program runs
    assert fake_ur.command("programstate").startswith("STOPPED")  # the controller's: it ended
    ur_robot.clear_protective_stop()
    assert_cleared_and_moving(ur_robot, fake_ur, start)
    # (the fake is left lagging: the fixture replaces it)


def test_a_move_right_after_clearing_an_emergency_stop_runs(ur_robot, fake_ur):
    assert fake_ur.command(f"fake program lag {LAG_S:g}") == f"fake: program lag {LAG_S:g}"
    start = ur_robot.actual_joints()
    assert fake_ur.command("fake estop") == "fake: emergency stop"
    wait_until(lambda: ur_robot.safety_state().emergency_stopped, what="the e-stop on the stream")
    for command in ("fake release estop", "power on", "brake release"):  # the operator
        fake_ur.command(command)
    wait_until(lambda: ur_robot.safety_state().ok, what="the release on the stream")
    ur_robot.clear_protective_stop()
    assert_cleared_and_moving(ur_robot, fake_ur, start)
