"""The ROS kinematics YAML: what the reader returns for files written by hand or
by the exporter, the notes on what the file cannot hold, and one-line refusals."""

import math
from dataclasses import replace

import numpy as np
import pytest
import yaml
from export_kit import calibrated, rot, urdf_origin

from calibrator import export
from calibrator.errors import CalibrationError
from calibrator.export import ros
from calibrator.model import kinematics

JOINTS = ("shoulder", "upper_arm", "forearm", "wrist_1", "wrist_2", "wrist_3")


def trailing_of(row):
    """``Tx(a6) Rx(alpha6) Ry(beta6)`` of the last MDH row, written out."""
    t = np.eye(4)
    t[:3, :3] = rot("x", row[kinematics.ALPHA]) @ rot("y", row[kinematics.BETA])
    t[0, 3] = row[kinematics.A]
    return t


def test_reader_gives_each_joint_axis_and_the_wrist_3_frame(tmp_path):
    cal = calibrated("ur10e", seed=21, trailing=True)
    path = tmp_path / "kin.yaml"
    path.write_text(export.export(cal, "ros-kinematics").text)
    joints, flange = ros.read(path)
    assert joints.shape == (6, 4, 4)
    _, frames = kinematics.chain(cal.mdh, np.zeros((1, 6)), all_frames=True)
    for i in range(6):
        # Joint i+1 turns about z of MDH frame i: same axis direction, and the
        # file's origin lies on that axis.
        axis, point = frames[0, i, :3, 2], frames[0, i, :3, 3]
        np.testing.assert_allclose(joints[i, :3, 2], axis, atol=1e-12)
        off = joints[i, :3, 3] - point
        np.testing.assert_allclose(off - (off @ axis) * axis, 0.0, atol=1e-6)
    # The wrist_3 frame is the flange without a6, alpha6, beta6.
    wrist_3 = frames[0, 6] @ np.linalg.inv(trailing_of(cal.mdh[5]))
    np.testing.assert_allclose(flange[:3, 3], wrist_3[:3, 3], atol=1e-6)
    np.testing.assert_allclose(flange[:3, :3], wrist_3[:3, :3], atol=1e-12)
    np.testing.assert_array_equal(flange, joints[5])


def hand_written():
    """A kinematics file with integer entries, as people type them (m, rad)."""
    return {
        "kinematics": {
            "shoulder": {"x": 0, "y": 0, "z": 0.2, "roll": 0, "pitch": 0, "yaw": 0},
            "upper_arm": {"x": 0, "y": 0, "z": 0, "roll": 1.5707963267948966, "pitch": 0, "yaw": 0},
            "forearm": {"x": -1, "y": 0, "z": 0, "roll": 0, "pitch": 0, "yaw": 0},
            "wrist_1": {"x": -0.5, "y": 0, "z": 0.1, "roll": 0, "pitch": 0, "yaw": 0},
            "wrist_2": {
                "x": 0,
                "y": -0.1,
                "z": 0,
                "roll": 1.5707963267948966,
                "pitch": 0,
                "yaw": 0,
            },
            "wrist_3": {"x": 0, "y": 0, "z": 0, "roll": 0, "pitch": 0, "yaw": 1},
        }
    }


def test_integer_entries_are_read_as_numbers(tmp_path):
    doc = hand_written()
    path = tmp_path / "kin.yaml"
    path.write_text(yaml.safe_dump(doc))
    joints, flange = ros.read(path)
    t = np.eye(4)
    for i, name in enumerate(JOINTS):
        j = doc["kinematics"][name]
        t = t @ urdf_origin(
            [j["x"] * 1000.0, j["y"] * 1000.0, j["z"] * 1000.0], [j["roll"], j["pitch"], j["yaw"]]
        )
        np.testing.assert_allclose(joints[i], t, atol=1e-9)
    np.testing.assert_allclose(flange, t, atol=1e-9)
    # Worked out by hand: x -1 m - 0.5 m; z 0.2 m, then -0.1 m along the rolled y (base z)
    assert flange[0, 3] == pytest.approx(-1500.0) and flange[2, 3] == pytest.approx(100.0)


def write_doc(tmp_path, doc, text=None):
    path = tmp_path / "kin.yaml"
    path.write_text(yaml.safe_dump(doc) if text is None else text)
    return path


@pytest.mark.parametrize(
    ("joint", "key", "value"),
    [
        ("forearm", "x", math.inf),
        ("wrist_1", "yaw", math.nan),
        ("upper_arm", "z", True),
        ("shoulder", "roll", "0.1"),
        ("wrist_3", "pitch", None),
    ],
)
def test_a_joint_entry_that_is_not_a_finite_number_is_refused(tmp_path, joint, key, value):
    doc = hand_written()
    doc["kinematics"][joint][key] = value
    path = write_doc(tmp_path, doc)
    with pytest.raises(CalibrationError) as info:
        ros.read(path)
    if isinstance(value, float):  # .inf, .nan: refused by the number grammar itself
        assert str(info.value).startswith(f"{path}: line ")
        assert "is not a decimal number" in str(info.value)
        return
    assert str(info.value) == (
        f"{path}: kinematics.{joint} needs finite numbers x, y, z, roll, pitch, yaw"
    )


@pytest.mark.parametrize(
    "doc",
    [
        ["kinematics", 1],
        {"kinematic": hand_written()["kinematics"]},
        {"kinematics": [1, 2]},
        {"kinematics": {k: v for k, v in hand_written()["kinematics"].items() if k != "wrist_3"}},
        {"kinematics": {**hand_written()["kinematics"], "elbow": {}, "forearm": 3}},
    ],
)
def test_a_file_without_the_six_joints_is_refused(tmp_path, doc):
    path = write_doc(tmp_path, doc)
    with pytest.raises(CalibrationError) as info:
        ros.read(path)
    assert str(info.value) == (
        f"{path}: no 'kinematics' with the joints "
        "shoulder, upper_arm, forearm, wrist_1, wrist_2, wrist_3"
    )


def test_a_file_that_is_not_yaml_names_the_first_line_of_the_parser_error(tmp_path):
    text = "kinematics:\n  shoulder: {x: [1, 2\n  upper_arm: 3\n"
    try:
        yaml.safe_load(text)
    except yaml.YAMLError as exc:
        first = str(exc).splitlines()[0]
        assert len(str(exc).splitlines()) > 1
    path = write_doc(tmp_path, None, text)
    with pytest.raises(CalibrationError) as info:
        ros.read(path)
    assert str(info.value).startswith(f"{path}: not YAML ({first}")  # and the line
    path.write_bytes(b"kinematics:\n  shoulder: \xff\xfe\n")
    with pytest.raises(CalibrationError, match=r"kin\.yaml: not YAML \("):
        ros.read(path)


def test_notes_name_what_the_file_cannot_hold():
    # Only a6: the flange is a6 mm along x from the wrist_3 frame.
    cal = calibrated("ur10e", trailing=False)
    assert export.export(cal, "ros-kinematics").notes == []
    mdh, nominal_mdh = cal.mdh.copy(), cal.nominal_mdh.copy()
    mdh[5, kinematics.A] = 0.5
    nominal_mdh[5, kinematics.A] = 0.5
    cal = replace(cal, mdh=mdh, nominal_mdh=nominal_mdh)
    (note,) = export.export(cal, "ros-kinematics").notes
    assert note == (
        "ros-kinematics cannot hold a6, alpha6, beta6: the flange is 0.5 mm and 0 rad "
        "from the wrist_3 frame (add it to the tool)"
    )
    # Only a turn (alpha6): no offset, 1 mrad.
    mdh[5, kinematics.A] = nominal_mdh[5, kinematics.A] = 0.0
    mdh[5, kinematics.ALPHA] = 1e-3
    cal = replace(cal, mdh=mdh, nominal_mdh=nominal_mdh)
    (note,) = export.export(cal, "ros-kinematics").notes
    assert "the flange is 0 mm and 0.001 rad from the wrist_3 frame" in note


def test_trailing_notes_limits():
    assert ros.trailing_notes(np.eye(4), "x") == []
    shift = np.eye(4)
    shift[1, 3] = 2e-9
    assert ros.trailing_notes(shift, "fmt")[0].startswith("fmt cannot hold a6, alpha6, beta6")
    turn = np.eye(4)
    turn[:3, :3] = rot("y", 2e-6)  # far above round-off, far below 1 rad
    assert len(ros.trailing_notes(turn, "fmt")) == 1
