"""verify.json on an arm whose controller's base frame is not the model's: the pendant's numbers.

The Yaskawa GP8's ROBOT frame sits 330 mm above its foot, where the model's
base is. The document's cube and commanded poses are in ROBOT, its joints are
the controller's, and a ``--cube`` given in ROBOT tests the same cube.
"""

import json

import numpy as np
from cli_process_kit import run_cli

from calibrator import robots
from calibrator.model import frames, kinematics

ARM = "yaskawa-gp8"


def test_the_cube_and_commanded_poses_are_in_the_controllers_base_frame(tmp_path):
    arm = robots.get(ARM)
    base = arm.model_base2controller_base
    assert abs(base[2, 3] - 330.0) < 1e-6
    args = ("verify", "--model", ARM, "--cycles", "2", "--seed", "3")
    done = run_cli(*args, "-o", "a.json", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    doc = json.loads((tmp_path / "a.json").read_text())
    tool = frames.transform(translation=[0.0, 0.0, 100.0])  # verify's default reflector
    for pose in doc["test_poses"]:
        q_model = arm.convention.to_model(np.array(pose["q_rad"]))
        at = frames.invert(base) @ kinematics.chain(arm.mdh, q_model[None]) @ tool
        # The nominal arm at the document's joints is at its commanded pose, in ROBOT.
        np.testing.assert_allclose(at[0, :3, 3], pose["commanded_mm"], atol=1e-6)
    # A cube about the same centre, given as the pendant states it (smaller: the largest
    # cube that fits is at the edge of what a given cube may be).
    centre = ",".join(repr(v) for v in doc["cube"]["centre_mm"])
    side = 0.8 * doc["cube"]["side_mm"]
    done = run_cli(*args, "--cube", f"{centre},{side!r}", "-o", "b.json", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    again = json.loads((tmp_path / "b.json").read_text())
    np.testing.assert_allclose(again["cube"]["centre_mm"], doc["cube"]["centre_mm"], atol=1e-9)
    # P1 is the cube's centre.
    np.testing.assert_allclose(again["test_poses"][0]["commanded_mm"], doc["cube"]["centre_mm"])
