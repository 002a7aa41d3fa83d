"""Collision meshes a URDF names: found as ROS finds them, or said to be missing.

A URDF copied out of its support package still describes the arm (identify
and export need only its joints); its body is then capsules along the links,
and the body's source names the first mesh not found and where it was looked
for, so nobody takes those capsules for the arm's housings.
"""

import numpy as np
import trimesh
from robot_files_kit import KUKA

from calibrator import robots

MESH = "package://my_arm_support/meshes/collision/link_2.stl"


def with_a_mesh(text):
    return text.replace(
        '<link name="link_2"/>',
        f'<link name="link_2"><collision><geometry><mesh filename="{MESH}"/></geometry>'
        "</collision></link>",
    )


def test_a_missing_mesh_is_named_and_the_arm_still_described(tmp_path, monkeypatch):
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    path = tmp_path / "arm.urdf"
    path.write_text(with_a_mesh(KUKA))
    arm = robots.get(str(path))
    np.testing.assert_array_equal(arm.mdh, robots.get(str(_plain(tmp_path))).mdh)
    assert f"collision meshes not found: {MESH}" in arm.body.source
    assert "ROS_PACKAGE_PATH" in arm.body.source
    assert {c.link for c in arm.body.capsules} == {1, 2, 3, 4, 5, 6}


def test_a_mesh_is_found_through_ros_package_path(tmp_path, monkeypatch):
    folder = tmp_path / "ws" / "my_arm_support" / "meshes" / "collision"
    folder.mkdir(parents=True)
    # A 0.5 m x 0.1 m x 0.1 m housing along link 2's x axis.
    trimesh.creation.box((0.5, 0.1, 0.1)).export(folder / "link_2.stl")
    path = tmp_path / "elsewhere" / "arm.urdf"
    path.parent.mkdir()
    path.write_text(with_a_mesh(KUKA))
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "ws"))
    arm = robots.get(str(path))
    assert "not found" not in arm.body.source
    (link_2,) = (c for c in arm.body.capsules if c.name == "link_2")
    # Enclosing the box's corners (its half diagonal across, 71 mm) plus the margin.
    assert 70.7 + 10 - 1e-6 < link_2.radius_mm < 70.8 + 10


def _plain(tmp_path):
    path = tmp_path / "plain.urdf"
    path.write_text(KUKA)
    return path
