"""A URDF without collision geometry, joint 1 on the mounting plane: link 1 stands on the base.

Link 1's capsule was drawn from joint 1's origin: on the plane at every
pose, so ``calibrator plan`` found no pose at all (0 of 400000 candidates
for ROS-Industrial's IRB 2400 without its meshes). The plan itself is made
in test_urdf_bare_body_cli.py.
"""

import numpy as np
from robot_files_kit import DATA, joint_1_on_the_plane

from calibrator import robots
from calibrator.model import kinematics


def test_link_1_stands_on_the_base_not_in_the_mounting_plane(tmp_path):
    path = tmp_path / "arm.urdf"
    path.write_text(joint_1_on_the_plane((DATA / "abb-irb4600-60-205.urdf").read_text()))
    arm, same = robots.get(str(path)), robots.get(str(DATA / "abb-irb4600-60-205.urdf"))
    q = np.random.default_rng(1).uniform(-1.0, 1.0, (20, 6))
    np.testing.assert_allclose(
        arm.base_offset @ kinematics.chain(arm.mdh, q) @ arm.flange_offset,
        same.base_offset @ kinematics.chain(same.mdh, q) @ same.flange_offset,
        atol=1e-9,
    )
    (link_1,) = (c for c in arm.body.capsules if c.link == 1)
    frame_1 = kinematics.chain(arm.mdh, np.zeros(6), all_frames=True)[1][0][1]
    lowest = min((frame_1 @ np.append(p, 1.0))[2] for p in (link_1.p_mm, link_1.q_mm))
    assert lowest - link_1.radius_mm > arm.body.mount_z_mm + arm.body.margin_mm
