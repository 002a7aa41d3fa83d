"""Robot-description cases the robots tests did not reach. Found by mutation testing (issue 44).

The shipped UR arms' joint ranges (the elbow half the others'), a
description's canonical content keeping its collision body, and a
description file with a key it does not know refused naming the known ones.
"""

from __future__ import annotations

import numpy as np
import pytest

from calibrator import robots
from calibrator.robots import DescriptionError, files, ur


@pytest.mark.parametrize("name", ["ur5e", "ur10e", "ur10"])
def test_a_ur_turns_every_joint_two_turns_but_the_elbow_one(name):
    turn = np.array([-2.0, 2.0]) * np.pi
    expected = np.array([turn, turn, turn / 2, turn, turn, turn])
    np.testing.assert_array_equal(robots.get(name).joint_limits_rad, expected)
    # As the module builds it (robots.get builds each arm once per process and
    # hands out copies): the same ranges.
    np.testing.assert_array_equal(ur.DESCRIPTIONS[name]().joint_limits_rad, expected)


def test_the_canonical_content_keeps_the_collision_body():
    arm = robots.get("ur10e")
    assert arm.body is not None
    body = arm.as_dict()["body"]
    assert body["base_radius_mm"] == arm.body.base_radius_mm
    assert body["shoulder_mm"] == list(arm.body.shoulder_mm)


def test_an_unknown_key_is_refused_naming_the_known_ones(tmp_path):
    path = tmp_path / "arm.yaml"
    path.write_text("format: calibrator-robot/1\nname: mine\nsource: a test\ncolour: red\n")
    with pytest.raises(DescriptionError) as refused:
        robots.get(str(path))
    said = str(refused.value)
    assert "colour" in said and f"unknown key (known: {', '.join(sorted(files._KEYS))})" in said


def test_given_joint_accelerations_are_kept_as_read_only_floats():
    import dataclasses

    arm = dataclasses.replace(robots.get("ur10e"), max_joint_accel_rad_s2=[3, 3, 3, 4, 4, 4])
    accel = arm.max_joint_accel_rad_s2
    assert isinstance(accel, np.ndarray) and accel.dtype == float
    np.testing.assert_array_equal(accel, [3.0, 3.0, 3.0, 4.0, 4.0, 4.0])
    assert not accel.flags.writeable


def _urdf(tmp_path, text):
    path = tmp_path / "arm.urdf"
    path.write_text(text)
    return path


def test_a_urdf_without_a_known_base_link_is_refused_naming_the_option(tmp_path):
    from robot_files_kit import KUKA

    from calibrator.robots import urdf

    path = _urdf(tmp_path, KUKA.replace('"base_link"', '"root_body"'))
    with pytest.raises(DescriptionError) as refused:
        urdf.read_chain(path)
    said = str(refused.value)
    assert said.startswith(str(path)) and "name it with --base-link" in said


def test_a_prismatic_joint_is_named_as_a_linear_axis(tmp_path):
    from robot_files_kit import KUKA

    from calibrator.robots import urdf

    text = KUKA.replace(
        '<joint name="joint_a1" type="revolute">', '<joint name="joint_a1" type="prismatic">'
    )
    assert text != KUKA
    with pytest.raises(
        DescriptionError, match=r"joint 'joint_a1' is prismatic \(a linear axis or track\)"
    ):
        urdf.read_chain(_urdf(tmp_path, text))


def test_a_named_base_link_that_is_not_there_is_refused_listing_the_links(tmp_path):
    from robot_files_kit import KUKA

    from calibrator.robots import urdf

    path = _urdf(tmp_path, KUKA)
    with pytest.raises(DescriptionError) as refused:
        urdf.read_chain(path, "nope")
    said = str(refused.value)
    assert "no base link 'nope' (links: " in said and "base_link" in said and "link_6" in said


def test_a_descriptions_configurations_are_read_only():
    arm = robots.get("ur10e")
    assert arm.configurations
    with pytest.raises(TypeError):
        arm.configurations["mine"] = (0.0,) * 6  # type: ignore[index]
