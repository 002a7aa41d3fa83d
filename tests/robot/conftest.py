"""Fixtures for the robot-link tests: the fake UR controller process and robot harnesses.

The fake listens on fixed ports (30004/29999/30003 on 127.0.0.1), so one fake
serves a whole test module and is replaced only when a test broke it (dropped,
stalled, still stopped) or needs another time scale. ``FakeUrProcess.start``
shuts down a fake left over from a crashed run, and every fake exits by
itself when the test process dies (``--parent-pid``).
"""

import numpy as np
import pytest
from robot_kit import wait_until

from drivers.robot.sim.device import SimulatedRobot
from drivers.robot.ur.simulator.launcher import FakeUrProcess, acquire_ports, release_ports

FAST = 10.0  # time scale of the fake: moves run ten times faster than on a robot


class FakeManager:
    """Keeps at most one fake controller process alive for the session."""

    def __init__(self):
        self.fake = None

    def running(self, time_scale=FAST):
        """A healthy fake with this time scale (reused when possible)."""
        if self.fake is not None and (
            not self.fake.running or self.fake.time_scale != time_scale or not self.healthy()
        ):
            self.discard()
        if self.fake is None:
            # Unlocks are refused 0 s after a stop here (5 s on a real controller).
            self.fake = FakeUrProcess(time_scale=time_scale, unlock_delay_s=0.0).start()
        return self.fake

    def healthy(self):
        try:
            return self.fake.command("fake status") == "fake: status normal"
        except OSError:
            return False

    def discard(self):
        if self.fake is not None:
            self.fake.stop()
            self.fake = None


@pytest.fixture(scope="module")
def fake_manager():
    # hold the ports while this module runs: another test run on this machine waits
    acquire_ports()
    manager = FakeManager()
    try:
        yield manager
    finally:
        manager.discard()
        release_ports()


@pytest.fixture
def fake_ur(fake_manager):
    """A running fake controller (time scale 10); replaced after a test that broke it."""
    fake = fake_manager.running()
    yield fake
    if not (fake.running and fake_manager.healthy()):
        fake_manager.discard()


@pytest.fixture
def ur_robot(fake_ur):
    """The ur-rtde adapter connected to the fake controller."""
    from drivers.robot.ur.device import UrRtdeRobot

    robot = UrRtdeRobot("127.0.0.1")
    robot.connect()
    yield robot
    robot.close()


class SimulatedHarness:
    """The simulated robot plus its simulation controls, for the shared suite."""

    name = "simulated"

    def __init__(self):
        self.robot = SimulatedRobot.from_model(
            "ur5e",
            np.random.default_rng(20241122),
            joint_noise_rad=1e-5,
            initial_q=[0.0, -1.5708, 1.5708, -1.5708, -1.5708, 0.0],
        )
        self.tolerance_rad = 1e-4

    def inject_protective_stop(self):
        self.robot.inject_protective_stop()

    def unlock_from_pendant(self):
        self.robot.unlock_from_pendant()

    def inject_emergency_stop(self):
        self.robot.inject_emergency_stop()

    def release_emergency_stop(self):
        self.robot.release_emergency_stop()

    def close(self):
        self.robot.close()


class FakeControllerHarness:
    """The ur-rtde adapter on the fake controller, faults injected over the dashboard."""

    name = "ur_rtde_fake"

    def __init__(self, fake):
        from drivers.robot.ur.device import UrRtdeRobot

        self.fake = fake
        self.robot = UrRtdeRobot("127.0.0.1")
        self.tolerance_rad = self.robot.tolerance_rad

    def _flag(self, attribute):
        return lambda: getattr(self.robot.safety_state(), attribute)

    def inject_protective_stop(self):
        assert self.fake.command("fake protective stop") == "fake: protective stop"
        wait_until(self._flag("protective_stopped"), what="protective stop over RTDE")

    def unlock_from_pendant(self):
        assert self.fake.command("unlock protective stop") == "Protective stop releasing"
        wait_until(lambda: not self.robot.safety_state().protective_stopped, what="unlock")

    def inject_emergency_stop(self):
        assert self.fake.command("fake estop") == "fake: emergency stop"
        wait_until(self._flag("emergency_stopped"), what="e-stop over RTDE")

    def release_emergency_stop(self):
        self.fake.command("fake release estop")
        wait_until(lambda: not self.robot.safety_state().emergency_stopped, what="e-stop release")
        # An e-stop powers the arm off: the operator powers on and releases the brakes.
        assert self.fake.command("power on") == "Powering on"
        assert self.fake.command("brake release") == "Brake releasing"

    def close(self):
        self.robot.close()


@pytest.fixture(params=["simulated", "ur_rtde_fake"])
def harness(request):
    """Each implementation of the robot interface, not yet connected."""
    if request.param == "simulated":
        h = SimulatedHarness()
    else:
        h = FakeControllerHarness(request.getfixturevalue("fake_ur"))
    yield h
    h.close()
