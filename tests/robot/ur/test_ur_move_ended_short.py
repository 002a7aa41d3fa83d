"""A UR move that ends short of its target names the joint that is furthest off, and by how much."""

import re
import threading
import time

import numpy as np
import pytest

from drivers.robot.errors import MotionFailed

pytest.importorskip("rtde_control")


def fake_joints(fake):
    reply = fake.command("fake joints")
    assert reply.startswith("fake: joints ")
    return np.array([float(v) for v in reply.split()[2:]])


def test_a_move_stopped_midway_names_the_joint_furthest_from_its_target(ur_robot, fake_ur):
    start = ur_robot.actual_joints()
    target = start + np.array([0.0, 0.0, 0.6, 0.0, 0.0, 0.0])  # only the elbow (J3) moves
    failed = []

    def stop_once_moving():
        deadline = time.monotonic() + 5.0
        while np.max(np.abs(fake_joints(fake_ur) - start)) < 0.05:
            if time.monotonic() > deadline:
                failed.append("the arm never moved")
                return
            time.sleep(0.002)
        ur_robot.stop()

    stopper = threading.Thread(target=stop_once_moving, daemon=True)
    stopper.start()
    with pytest.raises(MotionFailed) as err:
        ur_robot.move_joints(target, 0.1, 1.0)  # slow: seconds of margin for the stop
    stopper.join(10)
    assert not failed
    off = np.abs(ur_robot.actual_joints() - target)
    message = re.fullmatch(
        r"move ended away from its target: joint 3 off by (\S+) rad \(tolerance 0.001 rad\)",
        str(err.value),
    )
    assert message is not None, str(err.value)
    assert float(message.group(1)) == pytest.approx(off[2], abs=1e-3)
    assert 0.0 < off[2] < 0.6
