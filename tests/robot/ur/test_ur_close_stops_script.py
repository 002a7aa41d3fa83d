"""Closing the UR adapter leaves no control script running on the controller."""

import pytest

from drivers.robot.ur.device import UrRtdeRobot

pytest.importorskip("rtde_control")


def test_close_stops_the_control_script(fake_ur):
    robot = UrRtdeRobot("127.0.0.1")
    robot.connect()
    assert fake_ur.command("programstate") == "PLAYING rtde_control"
    robot.close()
    assert fake_ur.command("programstate") == "STOPPED <unnamed>"
