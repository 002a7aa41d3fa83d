"""The posed arm's building blocks against scipy's rotations and the project's kinematics."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from calibrator import robots
from calibrator.analysis import arm
from calibrator.errors import CalibrationError
from calibrator.model import kinematics

ANGLES = np.array([-2.5, -0.4, 0.0, 0.3, 1.2, 3.0])


@pytest.mark.parametrize("axis, build", [("x", arm.rot_x), ("y", arm.rot_y), ("z", arm.rot_z)])
def test_elementary_rotations_are_scipys(axis, build):
    out = build(ANGLES)
    assert out.shape == (len(ANGLES), 3, 4)
    np.testing.assert_allclose(
        out[..., :3], Rotation.from_euler(axis, ANGLES[:, np.newaxis]).as_matrix(), atol=1e-15
    )
    assert np.all(out[..., 3] == 0.0)
    assert build(0.7).shape == (3, 4)


def test_mdh_arm_with_tilted_axes_matches_the_kinematics():
    # Nonzero beta on every joint: the Ry part of each link tail is exercised.
    mdh = robots.get("ur5e").mdh.copy()
    mdh[:, kinematics.BETA] = [0.01, -0.02, 0.015, 0.03, -0.01, 0.02]
    q = np.radians([15.0, -70.0, 80.0, -20.0, 45.0, 100.0])
    posed = arm.mdh_arm(mdh, q)
    np.testing.assert_allclose(posed.base2hand(), kinematics.chain(mdh, q[np.newaxis])[0, :3])
    assert posed.name == "mdh"
    assert arm.mdh_arm(mdh, q, name="tilted").name == "tilted"


def test_bad_mdh_table_is_refused_with_the_kinematics_message():
    bad = np.zeros((5, 5))
    with pytest.raises(ValueError) as direct:
        kinematics.check_mdh(bad)
    with pytest.raises(CalibrationError) as info:
        arm.mdh_arm(bad, np.zeros(6))
    assert str(info.value) == str(direct.value) != ""
