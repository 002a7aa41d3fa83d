"""Where the measure workflow depends on it, the fake behaves like a real UR controller.

Tried with the real ``ur-rtde`` clients where the wire matters (TCP pose, setTcp,
commands the fake does not emulate); the power and unlock rules in-process.
"""

import numpy as np
import pytest
from robot_kit import wait_until
from timeout_kit import readline

from calibrator import robots
from calibrator.model import frames, kinematics, rotations
from drivers.robot.ur.simulator.controller import (
    HOME_Q,
    MODE_IDLE,
    MODE_POWER_OFF,
    MODE_RUNNING,
    RUNTIME_PLAYING,
    RUNTIME_STOPPED,
    SAFETY_NORMAL,
    SAFETY_PROTECTIVE_STOPPED,
    STATUS_PROGRAM_RUNNING,
    UNLOCK_DELAY_S,
    FakeController,
    tcp_pose,
)


def test_tcp_pose_is_right_through_a_tool_down_sweep():
    # Tool straight down: rotation angle pi, where axis signs are easy to lose.
    mdh = robots.get("ur5e").mdh
    sweep = np.tile(HOME_Q, (73, 1))
    sweep[:, 5] = np.linspace(-np.pi, np.pi, 73)
    sweep[:, 0] = np.linspace(-1.0, 1.0, 73)
    for q in sweep:
        truth = kinematics.forward(mdh, q[None])[0]
        pose = tcp_pose(q, mdh)
        np.testing.assert_allclose(rotations.rotvec_to_matrix(pose[3:]), truth[:3, :3], atol=1e-9)
        np.testing.assert_allclose(pose[:3] * 1000.0, truth[:3, 3], atol=1e-9)
        assert np.linalg.norm(pose[3:]) <= np.pi + 1e-12


def test_tcp_pose_over_rtde_with_set_tcp_and_a_tool_down_pose(ur_robot, fake_ur):
    import rtde_receive

    mdh = robots.get("ur5e").mdh
    receive = rtde_receive.RTDEReceiveInterface("127.0.0.1")
    try:
        q = HOME_Q + np.array([0.3, 0, 0, 0, 0, 2.0])  # tool still straight down
        reached = ur_robot.move_joints(q, 1.0, 4.0)
        flange = kinematics.forward(mdh, reached[None])[0]
        wait_until(lambda: np.allclose(receive.getActualQ(), reached, atol=1e-9), what="stream")
        pose = np.array(receive.getActualTCPPose())
        np.testing.assert_allclose(rotations.rotvec_to_matrix(pose[3:]), flange[:3, :3], atol=1e-6)
        np.testing.assert_allclose(pose[:3] * 1000, flange[:3, 3], atol=1e-3)
        # setTcp: the reported pose is the TCP's, 100 mm along the flange z axis.
        assert ur_robot._control.setTcp([0.0, 0.0, 0.1, 0.0, 0.0, 0.0])
        tcp = flange @ frames.transform(translation=[0, 0, 100.0])
        wait_until(
            lambda: np.allclose(np.array(receive.getActualTCPPose()[:3]) * 1000, tcp[:3, 3]),
            what="TCP pose with the new TCP",
        )
    finally:
        ur_robot._control.setTcp([0.0] * 6)
        receive.disconnect()


def test_commands_it_does_not_emulate_fail_visibly(ur_robot):
    control = ur_robot._control
    assert control.moveL([0.3, 0.2, 0.5, 0.0, 3.14, 0.0], 0.1, 0.1) is False
    assert not control.isProgramRunning()  # the script stopped, as on a script error
    assert control.getInverseKinematics([0.3, 0.2, 0.5, 0.0, 3.14, 0.0]) == []
    ur_robot.clear_protective_stop()  # restarts the control script
    assert control.isProgramRunning()


def test_unlock_refused_for_five_seconds_by_default_and_when_not_stopped():
    assert UNLOCK_DELAY_S == 5.0
    c = FakeController()
    assert c.unlock_delay_s == 5.0
    refused = "Cannot unlock protective stop, safetymode is not PROTECTIVE_STOP"
    assert c.unlock_protective_stop() == refused  # nothing to unlock
    c.protective_stop()
    assert c.unlock_protective_stop().startswith("Cannot unlock protective stop until 5s")
    c._protective_since -= 5.0  # as if 5 s had passed
    assert c.unlock_protective_stop() == "Protective stop releasing"
    assert c.unlock_protective_stop() == refused


def test_e_stop_powers_off_and_programs_wait_for_power_and_brakes():
    c = FakeController(unlock_delay_s=0.0)
    c.start_program()
    assert c.snapshot()["robot_mode"] == MODE_RUNNING and c.runtime_state == RUNTIME_PLAYING
    c.emergency_stop()
    assert c.snapshot()["robot_mode"] == MODE_POWER_OFF
    assert c.snapshot()["robot_status_bits"] & 1 == 0  # power bit off
    assert c.power_on().startswith("Cannot power on")  # e-stop still engaged
    c.release_emergency_stop()
    c.start_program()
    assert c.runtime_state == RUNTIME_STOPPED  # refused: powered off
    assert c.brake_release().startswith("Cannot release brakes")
    assert c.power_on() == "Powering on" and c.robot_mode == MODE_IDLE
    c.start_program()
    assert c.runtime_state == RUNTIME_STOPPED  # refused: brakes on
    assert c.brake_release() == "Brake releasing" and c.robot_mode == MODE_RUNNING
    c.start_program()
    assert c.runtime_state == RUNTIME_PLAYING
    assert c.power_off() == "Powering off"
    assert c.runtime_state == RUNTIME_STOPPED and c.robot_mode == MODE_POWER_OFF


def test_safety_lag_delays_the_streamed_bits_but_never_replays_older_ones():
    c = FakeController()
    c.emergency_stop()
    c.release_emergency_stop()
    # as if the e-stop had begun 6 s ago and been released 1 s ago (by an earlier test)
    (t0, start), (t1, stopped), *release = c._safety.log
    c._safety.log = [(t0 - 10.0, start), (t1 - 6.0, stopped)] + [(t - 1.0, b) for t, b in release]
    c.set_safety_lag(5.0)
    assert c.snapshot()["safety_status_bits"] == SAFETY_NORMAL  # the old stop is not replayed
    c.protective_stop()
    assert c.snapshot()["safety_status_bits"] == SAFETY_NORMAL  # the stream lags ...
    assert c.safety_bits & SAFETY_PROTECTIVE_STOPPED  # ... the controller (dashboard) does not
    t3, bits = c._safety.log[-1]
    c._safety.log[-1] = (t3 - 5.1, bits)  # as if 5.1 s had passed since the stop
    c._safety.lag_since -= 5.1
    assert c.snapshot()["safety_status_bits"] & SAFETY_PROTECTIVE_STOPPED
    assert c.snapshot()["safety_mode"] == 3
    c.set_safety_lag(0)
    assert c.snapshot()["safety_status_bits"] == c.safety_bits


def test_program_lag_delays_the_streamed_program_state_only():
    c = FakeController(unlock_delay_s=0.0)
    c.start_program()
    c.set_program_lag(5.0)
    c.protective_stop()
    assert c.runtime_state == RUNTIME_STOPPED  # the controller (dashboard) knows at once ...
    shown = c.snapshot()
    assert shown["runtime_state"] == RUNTIME_PLAYING  # ... the stream still shows it running
    assert shown["robot_status_bits"] & STATUS_PROGRAM_RUNNING
    assert shown["safety_status_bits"] & SAFETY_PROTECTIVE_STOPPED  # safety is not delayed
    t, state = c._runtime.log[-1]
    c._runtime.log[-1] = (t - 5.1, state)  # as if 5.1 s had passed since the stop
    c._runtime.lag_since -= 5.1
    shown = c.snapshot()
    assert shown["runtime_state"] == RUNTIME_STOPPED
    assert not shown["robot_status_bits"] & STATUS_PROGRAM_RUNNING
    c.set_program_lag(0)
    assert c.snapshot()["runtime_state"] == c.runtime_state


@pytest.mark.parametrize("name", ["ur5e", "ur10e"])
def test_model_comes_from_calibrator_models(name):
    c = FakeController(model=name)
    q = HOME_Q + 0.1
    c.q = q
    expected = kinematics.forward(robots.get(name).mdh, q[None])[0][:3, 3] / 1000
    np.testing.assert_allclose(c.snapshot()["actual_TCP_pose"][:3], expected, atol=1e-12)


def test_fake_exits_on_its_own_when_its_parent_is_killed(fake_manager):
    import subprocess
    import sys

    fake_manager.discard()  # free the fixed ports; this module still holds their lock
    parent_code = (
        "import os, subprocess, sys, time\n"
        "fake = subprocess.Popen([sys.executable, '-m', 'drivers.robot.ur.simulator', "
        "'--parent-pid', str(os.getpid())], stdout=subprocess.PIPE)\n"
        "print(fake.pid, flush=True)\n"
        "print(fake.stdout.readline().decode().strip(), flush=True)\n"
        "time.sleep(60)\n"
    )
    parent = subprocess.Popen(
        [sys.executable, "-c", parent_code], stdout=subprocess.PIPE, text=True
    )
    try:
        fake_pid = int(readline(parent.stdout, what="fake's pid"))
        assert "ready" in readline(parent.stdout, what="'ready'")
    finally:
        parent.kill()  # SIGKILL: the parent gets no chance to stop its child
        parent.wait(10)
        parent.stdout.close()

    def gone():
        try:
            with open(f"/proc/{fake_pid}/stat") as fh:
                return fh.read().split(")")[-1].split()[0] == "Z"
        except FileNotFoundError:
            return True

    wait_until(gone, timeout_s=5.0, what="the orphaned fake to exit")
