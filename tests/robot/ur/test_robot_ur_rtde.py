"""The real ``ur-rtde`` client (not a mock) against the fake controller in its own process.

First the bare client (``rtde_control`` / ``rtde_receive`` as shipped in the
wheel), then the adapter's semantics: stop mid-move, protective stop during a
move, e-stop, hang-up and a frozen controller, deadlines.
"""

import re
import threading
import time

import numpy as np
import pytest
from robot_kit import wait_until

from calibrator.acquire.ports import RobotHalted
from drivers.errors import ConnectionLost, DriverTimeout, NotReady
from drivers.robot.errors import EmergencyStop, MotionFailed, ProtectiveStop
from drivers.robot.ur.device import UrRtdeRobot, expected_move_time
from drivers.robot.ur.simulator.launcher import shutdown_leftover

rtde_control = pytest.importorskip("rtde_control")
rtde_receive = pytest.importorskip("rtde_receive")

HOST = "127.0.0.1"
TOL = 1e-3  # rad


def fake_is_moving(fake):
    return fake.command("fake moving") == "fake: moving true"


def fake_joints(fake):
    reply = fake.command("fake joints")
    assert reply.startswith("fake: joints ")
    return np.array([float(v) for v in reply.split()[2:]])


def wait_until_moved(fake, start, min_rad=0.05):
    """Wait until the fake's arm has travelled ``min_rad`` from ``start`` (on any joint)."""
    wait_until(
        lambda: np.max(np.abs(fake_joints(fake) - start)) > min_rad,
        what=f"the arm to move {min_rad} rad",
    )


def in_background(action):
    """Run ``action`` in a thread; returns a join function that re-raises its error."""
    errors = []

    def run():
        try:
            action()
        except Exception as exc:  # surfaced in the test thread by join()
            errors.append(exc)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()

    def join():
        thread.join(10)
        assert not thread.is_alive()
        if errors:
            raise errors[0]

    return join


# ------------------------------------------------------------- bare client
@pytest.fixture
def clients(fake_ur):
    receive = rtde_receive.RTDEReceiveInterface(HOST)
    control = rtde_control.RTDEControlInterface(HOST)
    yield control, receive
    control.stopScript()


def test_client_movej_reads_back_target(clients):
    control, receive = clients
    start = np.array(receive.getActualQ())
    target = start + np.array([0.2, -0.1, 0.1, 0.05, -0.05, 0.3])
    assert control.moveJ(target.tolist(), 1.0, 2.0) is True
    # actual_q may lag the move's end by one output period: poll with a tolerance
    wait_until(
        lambda: np.max(np.abs(np.array(receive.getActualQ()) - target)) < TOL,
        what="actual_q to reach the target",
    )
    assert control.isSteady() is True
    assert not receive.isProtectiveStopped()
    assert not receive.isEmergencyStopped()
    control.moveJ(start.tolist(), 1.0, 2.0)


def test_client_issteady_false_while_moving_and_stopj_halts(clients, fake_ur):
    control, receive = clients
    start = np.array(receive.getActualQ())
    target = start + np.array([1.0, 0, 0, 0, 0, 0])
    assert control.moveJ(target.tolist(), 0.3, 1.0, True) is True  # async
    assert control.isSteady() is False
    assert control.getAsyncOperationProgress() >= 0
    wait_until_moved(fake_ur, start)
    control.stopJ(2.0)
    assert control.isSteady() is True
    assert control.getAsyncOperationProgress() < 0
    time.sleep(0.05)  # two RTDE periods for actual_q to catch up
    q = np.array(receive.getActualQ())
    assert start[0] + 0.05 < q[0] < target[0] - 0.1  # stopped partway
    assert not fake_is_moving(fake_ur)


def test_client_timestamps_increase(clients):
    _, receive = clients
    stamps = [receive.getTimestamp()]

    def five_distinct():
        stamp = receive.getTimestamp()
        if stamp != stamps[-1]:
            stamps.append(stamp)
        return len(stamps) >= 5

    wait_until(five_distinct, what="five RTDE packages")
    assert all(b > a for a, b in zip(stamps, stamps[1:], strict=False))


# ----------------------------------------------------------------- adapter
def test_adapter_connect_refused_without_controller(fake_manager):
    fake_manager.discard()
    shutdown_leftover()  # nothing listens on 127.0.0.1:30004 now
    robot = UrRtdeRobot(HOST)
    with pytest.raises(ConnectionLost, match="could not connect"):
        robot.connect()


def test_adapter_requires_a_host():
    with pytest.raises(ValueError, match="^host is required$"):
        UrRtdeRobot("")


def test_the_adapters_defaults_are_the_documented_ones():
    # The end-of-move tolerance, the stale-data bound and the deadlines decide when
    # a move counts as done or the link as lost: a changed default must show in the
    # documentation ("name : float, default value").
    documented = dict(re.findall(r"^ {4}(\w+) : float, default (\S+)$", UrRtdeRobot.__doc__, re.M))
    robot = UrRtdeRobot(HOST)
    assert sorted(documented) == sorted(
        ["tolerance_rad", "stale_after_s", "timeout_margin_s", "poll_s", "command_timeout_s"]
    )
    for name, value in documented.items():
        assert getattr(robot, name) == float(value), name


def test_an_adapter_not_connected_says_to_connect_first():
    robot = UrRtdeRobot(HOST)
    calls = [
        robot.actual_joints,
        robot.safety_state,
        robot.stop,
        robot.clear_protective_stop,
        lambda: robot.move_joints(np.zeros(6), 0.1, 1.0),
    ]
    for call in calls:
        with pytest.raises(NotReady, match=r"^not connected; call connect\(\) first$"):
            call()


def test_stop_mid_move_reports_motion_failed(ur_robot, fake_ur):
    start = ur_robot.actual_joints()
    target = start + np.array([1.0, 0, 0, 0, 0, 0])

    def stop_when_moving():
        wait_until_moved(fake_ur, start)
        ur_robot.stop()

    join = in_background(stop_when_moving)
    with pytest.raises(MotionFailed, match="joint 1"):
        ur_robot.move_joints(target, 0.1, 1.0)  # slow: seconds of margin for the stop
    join()
    q = ur_robot.actual_joints()
    assert start[0] < q[0] < target[0]
    # a stop is not a safety stop: the next move is accepted
    np.testing.assert_allclose(ur_robot.move_joints(start, 1.0, 2.0), start, atol=TOL)


def test_protective_stop_during_move_is_typed_and_latched(ur_robot, fake_ur):
    start = ur_robot.actual_joints()
    target = start + np.array([0, 0.8, 0, 0, 0, 0])

    def trip_when_moving():
        wait_until_moved(fake_ur, start)
        fake_ur.command("fake protective stop")

    join = in_background(trip_when_moving)
    with pytest.raises(ProtectiveStop):
        ur_robot.move_joints(target, 0.1, 1.0)
    join()
    stopped_at = ur_robot.actual_joints()
    assert start[1] < stopped_at[1] < target[1]
    # unlocked on the "pendant": the adapter still refuses until cleared through it
    assert fake_ur.command("unlock protective stop") == "Protective stop releasing"
    wait_until(lambda: not ur_robot.safety_state().protective_stopped, what="unlock")
    with pytest.raises(ProtectiveStop):
        ur_robot.move_joints(start, 1.0, 2.0)
    np.testing.assert_allclose(ur_robot.actual_joints(), stopped_at, atol=TOL)
    ur_robot.clear_protective_stop()
    np.testing.assert_allclose(ur_robot.move_joints(start, 1.0, 2.0), start, atol=TOL)


def test_clear_waits_out_the_controllers_unlock_delay(ur_robot, fake_ur):
    # a real controller refuses "unlock protective stop" for 5 s after the stop
    assert fake_ur.command("fake unlock delay 1.0") == "fake: unlock delay 1"
    try:
        fake_ur.command("fake protective stop")
        wait_until(lambda: ur_robot.safety_state().protective_stopped, what="protective stop")
        with pytest.raises(NotReady, match="refused to unlock"):
            ur_robot.clear_protective_stop(timeout_s=0.1)
        assert ur_robot.safety_state().protective_stopped
        ur_robot.clear_protective_stop(timeout_s=5.0)  # retries until the delay has passed
        assert ur_robot.safety_state().ok
        start = ur_robot.actual_joints()
        np.testing.assert_allclose(
            ur_robot.move_joints(start + 0.01, 1.0, 2.0), start + 0.01, atol=TOL
        )
    finally:
        fake_ur.command("fake unlock delay 0")


def test_emergency_stop_during_move(ur_robot, fake_ur):
    start = ur_robot.actual_joints()

    def estop_when_moving():
        wait_until_moved(fake_ur, start)
        fake_ur.command("fake estop")

    join = in_background(estop_when_moving)
    with pytest.raises(EmergencyStop):
        ur_robot.move_joints(start + np.array([0, 0, 0.8, 0, 0, 0]), 0.1, 1.0)
    join()
    assert ur_robot.safety_state().emergency_stopped
    fake_ur.command("fake release estop")
    wait_until(lambda: ur_robot.safety_state().ok, what="e-stop release")
    # The e-stop powered the arm off: nothing runs until power on and brake release.
    with pytest.raises(NotReady, match="robot mode 3"):
        ur_robot.clear_protective_stop()
    assert fake_ur.command("robotmode") == "Robotmode: POWER_OFF"
    assert fake_ur.command("power on") == "Powering on"
    assert fake_ur.command("robotmode") == "Robotmode: IDLE"
    with pytest.raises(NotReady, match="robot mode 5"):
        ur_robot.clear_protective_stop()
    assert fake_ur.command("brake release") == "Brake releasing"
    assert fake_ur.command("robotmode") == "Robotmode: RUNNING"
    ur_robot.clear_protective_stop()
    np.testing.assert_allclose(ur_robot.move_joints(start, 1.0, 2.0), start, atol=TOL)


@pytest.mark.parametrize(
    ("inject", "error"),
    [
        ("fake estop", EmergencyStop),  # pressed just before the move: script gone
        ("fake estop at movej 1", EmergencyStop),  # pressed as the move arrives: refused
        ("fake protective stop", ProtectiveStop),
    ],
)
def test_stop_the_stream_shows_late_is_reported_as_that_stop(ur_robot, fake_ur, inject, error):
    # The receive stream may show a stop periods after the control stream failed the
    # move (two streams, a starved thread): the failure must still read as the stop.
    assert fake_ur.command("fake safety lag 5") == "fake: safety lag 5"
    start = ur_robot.actual_joints()
    assert fake_ur.command(inject).startswith("fake:")
    assert ur_robot.safety_state().ok  # the stream does not show it yet
    with pytest.raises(error, match="dashboard"):
        ur_robot.move_joints(start + 0.2, 1.0, 2.0)
    np.testing.assert_array_equal(fake_joints(fake_ur), np.round(start, 9))
    with pytest.raises(RobotHalted):  # latched: refused again, still nothing moves
        ur_robot.move_joints(start + 0.2, 1.0, 2.0)
    # (the fake is left stopped and lagging: the fixture replaces it)


def test_refused_move_without_a_stop_stays_a_motion_failure(ur_robot, fake_ur):
    # a program stopped on the pendant is no safety stop: not reported as one
    start = ur_robot.actual_joints()
    assert fake_ur.command("stop") == "Stopped"
    # refused by the controller, or seen as "script not running" first: either way no stop
    with pytest.raises((MotionFailed, NotReady), match="refused|not running") as failed:
        ur_robot.move_joints(start + 0.2, 1.0, 2.0)
    assert not isinstance(failed.value, RobotHalted)
    ur_robot.clear_protective_stop()  # restarts the script
    np.testing.assert_allclose(ur_robot.move_joints(start + 0.2, 1.0, 2.0), start + 0.2, atol=TOL)


def test_triggered_protective_stop_from_client(ur_robot):
    # the client's own triggerProtectiveStop (command 31) goes through the script loop
    ur_robot._control.triggerProtectiveStop()
    wait_until(lambda: ur_robot.safety_state().protective_stopped, what="protective stop")
    with pytest.raises(ProtectiveStop):
        ur_robot.move_joints(ur_robot.actual_joints(), 1.0, 2.0)
    ur_robot.clear_protective_stop()
    assert ur_robot.safety_state().ok


@pytest.mark.parametrize(
    "fault, first, reason",
    [
        # "drop": the controller closes every socket
        ("fake drop", r"lost the RTDE connection to 127\.0\.0\.1", r"RTDE connection closed"),
        # "stall": sockets stay open, data stops (after the 1 s bound; a busy machine adds)
        (
            "fake stall",
            r"no RTDE data from 127\.0\.0\.1 for [1-9]\.\d\d s \(controller hung up\?\)",
            r"no RTDE data for [1-9]\.\d\d s",
        ),
    ],
)
def test_controller_hangup_during_move_is_connection_lost(ur_robot, fake_ur, fault, first, reason):
    start = ur_robot.actual_joints()

    def fault_when_moving():
        wait_until_moved(fake_ur, start)
        fake_ur.command(fault)

    join = in_background(fault_when_moving)
    t0 = time.monotonic()
    with pytest.raises(ConnectionLost, match=f"^{first}$"):
        ur_robot.move_joints(start + np.array([0, 0, 0, 0, 0, 2.0]), 0.1, 1.0)
    elapsed = time.monotonic() - t0
    join()
    # the deadline that matters: the client alone would wait out its 300 s timeout
    assert elapsed < ur_robot.stale_after_s + 5.0
    # Later calls refuse at once, naming what was lost and what to do.
    with pytest.raises(
        ConnectionLost, match=rf"^link to 127\.0\.0\.1 lost earlier \({reason}\); reconnect$"
    ):
        ur_robot.actual_joints()


def test_move_overrunning_its_deadline_times_out_and_stops(fake_manager):
    # at time scale 0.2 the fake moves 5x slower than the adapter expects
    fake = fake_manager.running(time_scale=0.2)
    robot = UrRtdeRobot(HOST, timeout_margin_s=0.2)
    with robot:
        start = robot.actual_joints()
        target = start + np.array([0.3, 0, 0, 0, 0, 0])
        expected = expected_move_time(start, target, 3.0, 10.0)
        deadline = expected + robot.timeout_margin_s
        with pytest.raises(DriverTimeout) as err:
            robot.move_joints(target, 3.0, 10.0)
        assert str(err.value) == f"move did not finish within {deadline:.1f} s; stopped"
        assert not fake_is_moving(fake)  # the adapter stopped the arm
        q = robot.actual_joints()
        assert start[0] < q[0] < target[0]
        assert expected < 0.5
    fake_manager.discard()


def test_expected_move_time_matches_trapezoid_and_triangle():
    # 1 rad at 0.5 rad/s, 1 rad/s^2: two 0.5 s ramps (0.125 rad each), 0.75 rad cruise (1.5 s)
    assert expected_move_time(np.zeros(6), np.r_[1.0, np.zeros(5)], 0.5, 1.0) == pytest.approx(2.5)
    # 0.01 rad never reaches 0.5 rad/s: triangle, 2 * sqrt(0.01 / 1)
    assert expected_move_time(np.zeros(6), np.r_[0.01, np.zeros(5)], 0.5, 1.0) == pytest.approx(0.2)
    # the same with 2 rad/s^2 (a unit acceleration hides a swapped * and /):
    # 0.3 rad cruises (0.6 s) between two 0.125 s ramps; 0.1 rad peaks at 0.447 rad/s
    q = np.r_[0.0, 0.0, -0.3, 0.0, 0.0, 0.0]  # the leading joint need not be the first
    assert expected_move_time(np.zeros(6), q, 0.5, 2.0) == pytest.approx(0.85)
    assert expected_move_time(q, np.zeros(6), 0.5, 2.0) == pytest.approx(0.85)
    triangle = expected_move_time(np.zeros(6), np.r_[0.1, np.zeros(5)], 0.5, 2.0)
    assert triangle == pytest.approx(2 * np.sqrt(0.1 / 2.0))


def test_a_stop_present_at_connect_is_typed_and_a_cleared_arm_connects(fake_ur):
    """Stopped before we connect: refused as the stop it is (no control script can run)."""
    fake_ur.command("fake protective stop")
    wait_until(lambda: fake_ur.command("fake status") != "fake: status normal", what="stop")
    robot = UrRtdeRobot(HOST)
    with pytest.raises(ProtectiveStop, match="^UR controller at 127.0.0.1 is safety-stopped"):
        robot.connect()
    # unlocked on the pendant: a new connection works and moves
    assert fake_ur.command("unlock protective stop") == "Protective stop releasing"
    wait_until(lambda: fake_ur.command("fake status") == "fake: status normal", what="unlock")
    robot.connect()
    try:
        assert robot.safety_state().ok
        start = robot.actual_joints()
        np.testing.assert_allclose(robot.move_joints(start, 1.0, 2.0), start, atol=TOL)
    finally:
        robot.close()
