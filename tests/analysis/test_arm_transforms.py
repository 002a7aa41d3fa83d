"""The posed arm against scipy's rotations and the project's kinematics."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from calibrator import robots
from calibrator.analysis import arm
from calibrator.errors import CalibrationError
from calibrator.model import kinematics

ANGLES = np.array([-2.5, -0.4, 0.0, 0.3, 1.2, 3.0])


def test_the_links_are_the_kinematics_joint_origins_turned_to_the_pose():
    # The posed arm is built by the model's one forward kinematics: L_i = O_i Rz(q_i).
    mdh = robots.get("ur5e").mdh.copy()
    mdh[:, kinematics.BETA] = 0.01
    q = np.radians([15.0, -70.0, 80.0, -20.0, 45.0, 100.0])
    origins, trailing = kinematics.joint_origins(mdh)
    posed = arm.mdh_arm(mdh, q)
    for i in range(6):
        turn = np.eye(4)
        turn[:3, :3] = Rotation.from_euler("z", q[i]).as_matrix()
        np.testing.assert_allclose(posed.links[i], (origins[i] @ turn)[:3], atol=1e-12)
    np.testing.assert_array_equal(posed.tail, trailing[:3])
    assert posed.links.shape == (6, 3, 4) and posed.tail.shape == (3, 4)


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
