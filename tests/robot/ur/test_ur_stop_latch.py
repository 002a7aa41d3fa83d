"""A stop the UR adapter has reported stays latched until cleared through the adapter.

Also the refusals of ``clear_protective_stop`` itself: during an e-stop, and
when the stream still shows the stop after the controller accepted the unlock.
The fake controller's ``safety lag`` makes its stream show safety changes late,
as a loaded controller or host does.
"""

import threading
import time

import numpy as np
import pytest
from robot_kit import wait_until

from drivers.errors import DriverTimeout, NotReady
from drivers.robot.errors import EmergencyStop, ProtectiveStop

pytest.importorskip("rtde_control")

LAG_S = 1.0  # the stream shows safety changes this late

RELEASES = {
    "fake protective stop": ["unlock protective stop"],
    "fake estop": ["fake release estop", "power on", "brake release"],
}


@pytest.mark.parametrize(
    ("inject", "error"),
    [("fake protective stop", ProtectiveStop), ("fake estop", EmergencyStop)],
)
def test_a_stop_only_the_dashboard_reported_stays_latched_after_a_release_elsewhere(
    ur_robot, fake_ur, inject, error
):
    assert fake_ur.command("fake safety lag 1") == "fake: safety lag 1"
    start = ur_robot.actual_joints()
    assert fake_ur.command(inject).startswith("fake:")
    # the stream does not show the stop yet: the failed move asks the dashboard
    with pytest.raises(error, match="dashboard"):
        ur_robot.move_joints(start + 0.2, 1.0, 2.0)
    for command in RELEASES[inject]:  # released on the pendant, at once
        fake_ur.command(command)
    released_at = time.monotonic()
    # Not asked for its safety state meanwhile (the stream's late view of the
    # stop would latch it again): the adapter's own latch must hold the move.
    time.sleep(max(0.0, released_at + LAG_S + 0.3 - time.monotonic()))
    with pytest.raises(ProtectiveStop, match=r"call clear_protective_stop\(\) first"):
        ur_robot.move_joints(start + 0.2, 1.0, 2.0)
    np.testing.assert_allclose(ur_robot.actual_joints(), start, atol=1e-9)
    ur_robot.clear_protective_stop()
    np.testing.assert_allclose(ur_robot.move_joints(start, 1.0, 2.0), start, atol=1e-3)
    # (the fake is left lagging: the fixture replaces it)


def test_clearing_during_an_emergency_stop_is_refused_for_the_operator(ur_robot, fake_ur):
    assert fake_ur.command("fake estop") == "fake: emergency stop"
    wait_until(lambda: ur_robot.safety_state().emergency_stopped, what="the e-stop on the stream")
    with pytest.raises(
        EmergencyStop, match="^emergency stop engaged: an operator must release it$"
    ):
        ur_robot.clear_protective_stop()
    # (the fake is left e-stopped: the fixture replaces it)


def test_clearing_times_out_naming_the_stop_the_stream_still_shows(ur_robot, fake_ur):
    assert fake_ur.command("fake safety lag 3") == "fake: safety lag 3"
    assert fake_ur.command("fake protective stop") == "fake: protective stop"
    wait_until(lambda: ur_robot.safety_state().protective_stopped, 5.0, "the stop on the stream")
    # the controller unlocks at once, but the stream shows the stop 3 s longer
    with pytest.raises(
        DriverTimeout, match="^timed out after 0.5 s waiting for protective stop to clear$"
    ):
        ur_robot.clear_protective_stop(timeout_s=0.5)
    # (the fake is left lagging: the fixture replaces it)


def test_clearing_times_out_naming_the_control_script_that_does_not_start(ur_robot, fake_ur):
    # The stream does not show the stop yet (3 s late), so nothing is unlocked; the
    # controller refuses to start the re-uploaded script while it is stopped.
    assert fake_ur.command("fake safety lag 3") == "fake: safety lag 3"
    assert fake_ur.command("fake protective stop") == "fake: protective stop"
    assert fake_ur.command("programstate") == "STOPPED <unnamed>"
    time.sleep(0.2)  # the program's end reaches the control stream (2 ms periods)
    with pytest.raises(
        DriverTimeout, match="^timed out after 0.5 s waiting for control script to start$"
    ):
        ur_robot.clear_protective_stop(timeout_s=0.5)
    # (the fake is left stopped and lagging: the fixture replaces it)


def test_clearing_an_unpowered_arm_says_what_the_operator_must_do(ur_robot, fake_ur):
    assert fake_ur.command("fake estop") == "fake: emergency stop"
    # the stream shows the e-stop, then its release, within 3 s together
    deadline = time.monotonic() + 3.0
    wait_until(lambda: ur_robot.safety_state().emergency_stopped, what="the e-stop on the stream")
    fake_ur.command("fake release estop")
    left = deadline - time.monotonic()
    wait_until(lambda: ur_robot.safety_state().ok, left, "the e-stop release on the stream")
    # the e-stop powered the arm off (robot mode 3): no program can run
    with pytest.raises(NotReady) as refused:
        ur_robot.clear_protective_stop()
    assert str(refused.value) == (
        "UR controller at 127.0.0.1 is not running (robot mode 3): power the arm on and "
        "release the brakes (pendant or dashboard), then retry"
    )
    # (the fake is left powered off: the fixture replaces it)


@pytest.mark.parametrize(
    ("inject", "error", "message"),
    [
        ("fake estop", EmergencyStop, "^emergency stop engaged$"),
        (
            "fake protective stop",
            ProtectiveStop,
            "^protective stop: the controller stopped the arm$",
        ),
    ],
)
def test_a_stop_that_ended_a_move_stays_latched_after_its_release(
    ur_robot, fake_ur, inject, error, message
):
    start = ur_robot.actual_joints()
    target = start + np.array([0.0, 0.0, 0.8, 0.0, 0.0, 0.0])

    def estop_once_moving():
        deadline = time.monotonic() + 5.0
        while fake_ur.command("fake moving") != "fake: moving true":
            if time.monotonic() > deadline:
                return
            time.sleep(0.002)
        fake_ur.command(inject)

    presser = threading.Thread(target=estop_once_moving, daemon=True)
    presser.start()
    with pytest.raises(error, match=message):
        ur_robot.move_joints(target, 0.1, 1.0)  # slow: the stop comes mid-move
    presser.join(10)
    # released on the pendant (powered, brakes off), the adapter not asked meanwhile
    for command in RELEASES[inject]:
        fake_ur.command(command)
    assert fake_ur.command("fake status") == "fake: status normal"
    time.sleep(0.3)  # the stream shows the release (2 ms periods)
    stopped_at = ur_robot.actual_joints()
    with pytest.raises(ProtectiveStop) as refused:
        ur_robot.move_joints(start, 1.0, 2.0)
    assert str(refused.value) == "the arm was safety-stopped; call clear_protective_stop() first"
    np.testing.assert_allclose(ur_robot.actual_joints(), stopped_at, atol=1e-9)
    ur_robot.clear_protective_stop()
    np.testing.assert_allclose(ur_robot.move_joints(start, 1.0, 2.0), start, atol=1e-3)


def test_a_program_stopped_on_the_pendant_is_refused_as_not_running(ur_robot, fake_ur):
    start = ur_robot.actual_joints()
    assert fake_ur.command("stop") == "Stopped"
    assert fake_ur.command("programstate") == "STOPPED <unnamed>"
    time.sleep(0.2)  # the program's end reaches the control stream (2 ms periods)
    with pytest.raises(NotReady) as refused:
        ur_robot.move_joints(start + 0.2, 1.0, 2.0)
    assert str(refused.value) == (
        "the rtde_control script is not running (stopped on the pendant or by a safety stop); "
        "call clear_protective_stop() to restart it"
    )
    assert not isinstance(refused.value, (EmergencyStop, ProtectiveStop))
