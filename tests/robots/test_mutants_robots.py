"""Robot-description cases the robots tests did not reach (found by mutmut, issue 44).

The shipped UR arms' joint ranges (the elbow half the others'), a
description's canonical content keeping its collision body, and a
description file with a key it does not know refused naming the known ones.
"""

from __future__ import annotations

import numpy as np
import pytest

from calibrator import robots
from calibrator.robots import DescriptionError, files


@pytest.mark.parametrize("name", ["ur5e", "ur10e", "ur10"])
def test_a_ur_turns_every_joint_two_turns_but_the_elbow_one(name):
    turn = np.array([-2.0, 2.0]) * np.pi
    expected = np.array([turn, turn, turn / 2, turn, turn, turn])
    np.testing.assert_array_equal(robots.get(name).joint_limits_rad, expected)


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
