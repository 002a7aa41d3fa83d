"""Another arm's kinematics YAML: its URDF's joint names, its controller's angles.

Read back with PyYAML and chained by hand (``origin_i . Rz(q_i)``) at the
controller's angles of random poses, the file is the calibrated chain up to
the flange transform it cannot hold; a controller coupling (FANUC's J2/J3)
is named in a note by both formats that cannot hold it.
"""

import numpy as np
import pytest
import yaml
from export_kit import calibrated, poses, rot, urdf_origin

from calibrator import export, robots
from calibrator.model import kinematics


def chain_of_yaml(text, q):
    """wrist frame (N, 4, 4) of the file's joints at angles q (N, 6), mm."""
    doc = yaml.safe_load(text)["kinematics"]
    keys = [k for k in doc if k != "hash"]
    out = []
    for row in q:
        t = np.eye(4)
        for i, key in enumerate(keys):
            o = doc[key]
            t = t @ urdf_origin(np.array([o["x"], o["y"], o["z"]]) * 1000.0,
                                [o["roll"], o["pitch"], o["yaw"]])  # fmt: skip
            spin = np.eye(4)
            spin[:3, :3] = rot("z", row[i])
            t = t @ spin
        out.append(t)
    return keys, np.array(out)


@pytest.mark.parametrize(
    "model, names",
    [
        ("kuka-kr6-r900", [f"joint_a{i}" for i in range(1, 7)]),
        ("yaskawa-gp8", ["joint_1_s", "joint_2_l", "joint_3_u", "joint_4_r", "joint_5_b",
                         "joint_6_t"]),
    ],
)  # fmt: skip
def test_yaml_names_the_urdfs_joints_and_turns_them_by_the_controllers_angles(model, names):
    cal = calibrated(model, seed=5)
    result = export.export(cal, "ros-kinematics")
    q = poses(40, seed=2)
    keys, wrist = chain_of_yaml(result.text, robots.get(model).convention.to_controller(q))
    assert keys == names
    # The file's last frame is the flange up to the transform the note names.
    flange = kinematics.chain(cal.mdh, q)
    rest = np.linalg.inv(wrist[0]) @ flange[0]
    np.testing.assert_allclose(wrist @ rest, flange, rtol=0, atol=1e-6)
    assert any(f"from the {names[5]} frame" in note for note in result.notes)


def test_a_controller_coupling_is_named_by_both_formats():
    cal = calibrated("fanuc-m20ia", seed=5)
    for fmt in ("ros-kinematics", "urdf"):
        notes = export.export(cal, fmt).notes
        assert any("coupling of joint_3 to joint_2" in n for n in notes), (fmt, notes)
    assert not any("coupling" in n for n in export.export(calibrated("ur10e"), "urdf").notes)
