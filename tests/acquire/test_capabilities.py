"""Capabilities: declared by the driver and checked against the protocol of their methods."""

import numpy as np
import pytest

from calibrator.acquire import ports


class Declares:
    capabilities = frozenset({ports.SEARCH, ports.STEER})

    def find_reflector(self, predicted_point_mm):
        self.asked = predicted_point_mm


class Undeclared:
    capabilities = frozenset()

    def find_reflector(self, predicted_point_mm):
        pass


def test_a_capability_is_offered_when_declared_and_its_methods_exist():
    device = Declares()
    assert ports.SEARCH.offered_by(device)
    # Declared, but set_target is missing: not offered (no AttributeError later).
    assert not ports.STEER.offered_by(device)
    # Has the method, but a wrapper may have methods it cannot serve: not declared, not offered.
    assert not ports.SEARCH.offered_by(Undeclared())
    assert not ports.SEARCH.offered_by(object())


def test_a_capability_is_still_the_name_drivers_declare():
    assert ports.SEARCH == "search" and "search" in Declares.capabilities
    assert ports.REPORTS_CONDITIONS.protocol is ports.ReportsConditions


def test_a_guarded_robot_forwards_temperatures_only_of_a_robot_that_reports_them():
    from calibrator import robots
    from drivers.robot.safety import GuardedRobot, MotionLimits
    from drivers.robot.sim.device import SimulatedRobot

    model = robots.get("ur10e")
    inner = SimulatedRobot(model.mdh, np.eye(4), np.eye(4))
    guarded = GuardedRobot(inner, MotionLimits.from_model(model))
    assert ports.CHECKS_PLAN.offered_by(guarded)
    assert not ports.REPORTS_TEMPERATURES.offered_by(guarded)
    with pytest.raises(NotImplementedError, match="SimulatedRobot reports no joint temperatures"):
        guarded.joint_temperatures()
