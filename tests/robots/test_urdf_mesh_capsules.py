"""Capsules fitted to a URDF's collision meshes: every vertex inside, and no fatter than needed.

ROS-Industrial's IRB 2400 got a 506 mm capsule for a turret 833 mm across at
most, and a mounting plane 263 mm below the one its base stands on: the
capsule axis came from the mean of the vertices (pulled towards wherever a
mesh is finely drawn) and the plane from the base capsule's round end. A plan
for it was then refused (2 of 9000 candidates passed) or let the arm reach
below its plane.
"""

import numpy as np
import trimesh
from robot_files_kit import KUKA
from urdf_mesh_kit import PACKAGE, arm_with_meshes, housings

from calibrator.model import kinematics
from calibrator.robots import enclosing, urdf


def _in_model_frames(arm, chain, name, link, points_m):
    """Points of link ``name`` (its URDF frame, m) in the MDH frame of ``link`` (mm)."""
    frames = arm.base_offset @ kinematics.chain(arm.mdh, np.zeros(6), all_frames=True)[1][0]
    to_model = np.linalg.inv(frames[link]) @ chain.link_frames()[name]
    return points_m * 1000 @ to_model[:3, :3].T + to_model[:3, 3]


def _distance(capsule, points):
    p, q = np.asarray(capsule.p_mm), np.asarray(capsule.q_mm)
    t = np.clip((points - p) @ (q - p) / max((q - p) @ (q - p), 1e-300), 0, 1)
    return np.linalg.norm(points - (p + t[:, None] * (q - p)), axis=1)


def test_a_mesh_link_gets_a_capsule_holding_every_vertex_and_no_fatter(tmp_path):
    # A housing 200 mm across and 600 mm long, finely drawn on one side inside
    # (a motor's detail): the mean of its vertices lies 62 mm off its axis.
    housing = trimesh.creation.cylinder(radius=0.1, height=0.6, sections=64)
    detail = trimesh.creation.icosphere(subdivisions=4, radius=0.02)
    detail.apply_translation((0.07, 0.0, 0.25))
    mesh = trimesh.util.concatenate([housing, detail])
    assert np.linalg.norm(mesh.vertices.mean(axis=0)[:2]) > 0.06
    # Put on link 3 turned and moved, as a URDF's <collision><origin> may.
    origin = '<origin xyz="0.2 0.01 0.03" rpy="0.1 1.4 -0.2"/>'
    path = arm_with_meshes(tmp_path, {"link_3": mesh}, origin)
    arm = urdf.describe(path, margin_mm=0.0)
    chain = urdf.read_chain(path)
    (capsule,) = (c for c in arm.body.capsules if c.link == 3)
    placed = trimesh.transformations.compose_matrix(
        angles=(0.1, 1.4, -0.2), translate=(0.2, 0.01, 0.03)
    )
    vertices = trimesh.transform_points(mesh.vertices, placed)
    inside = _in_model_frames(arm, chain, "link_3", 3, vertices)
    assert _distance(capsule, inside).max() <= capsule.radius_mm + 1e-6
    # The cylinder's own capsule: 100 mm (its 64-gon's corners) around its 600 mm axis.
    assert 99.99 < capsule.radius_mm < 100.001  # STL stores single precision
    assert np.linalg.norm(np.subtract(capsule.q_mm, capsule.p_mm)) < 600.001


def test_every_link_with_a_mesh_gets_its_own_capsule_and_the_base_stands_on_its_plane(tmp_path):
    meshes = housings()
    arm = urdf.describe(arm_with_meshes(tmp_path, meshes), margin_mm=5.0)
    chain = urdf.read_chain(tmp_path / PACKAGE / "urdf" / "arm.urdf")
    assert "fitted to the collision geometry" in arm.body.source
    assert "along the links" not in arm.body.source
    for link in range(1, 7):
        (capsule,) = (c for c in arm.body.capsules if c.link == link)
        name = f"link_{link}"
        inside = _in_model_frames(arm, chain, name, link, meshes[name].vertices)
        gap = capsule.radius_mm - _distance(capsule, inside)
        # Every vertex inside, some on the surface: the margin is the only slack.
        assert 5.0 - 1e-3 <= gap.min() < 5.0 + 1e-3, name  # STL: single precision
    # The base box stands on the base link's z = 0: the mounting plane is there
    # (in MDH frame 0, which sits base_offset above the base link), not a radius lower.
    assert abs(arm.body.mount_z_mm + arm.base_offset[2, 3]) < 1e-9


def test_a_base_cylinder_standing_on_z_0_puts_the_mounting_plane_there(tmp_path):
    base = (
        '<link name="base_link"><collision><origin xyz="0 0 0.15" rpy="0 0 0"/>'
        '<geometry><cylinder radius="0.15" length="0.3"/></geometry></collision></link>'
    )
    path = tmp_path / "arm.urdf"
    path.write_text(KUKA.replace('<link name="base_link"/>', base))
    arm = urdf.describe(path)
    # Its rims are on z = 0; the capsule's round end 150 mm lower is not the floor.
    assert abs(arm.body.mount_z_mm + arm.base_offset[2, 3]) < 1e-9


def test_the_capsule_holds_any_cloud_and_is_no_larger_than_along_its_principal_axis():
    rng = np.random.default_rng(7)
    for n in (1, 2, 3, 7, 50, 400):
        points = rng.normal(size=(n, 3)) * rng.uniform(1.0, 300.0, 3) + rng.uniform(-500, 500, 3)
        capsule = enclosing.enclose(points)
        d = capsule.q - capsule.p
        t = np.clip((points - capsule.p) @ d / max(d @ d, 1e-300), 0.0, 1.0)
        assert np.linalg.norm(points - capsule.p - t[:, None] * d, axis=1).max() <= capsule.radius
        # The capsule from the mean along the principal axis (the fit before): never smaller.
        centre = points.mean(axis=0)
        axis = np.linalg.svd(points - centre)[2][0]
        along = (points - centre) @ axis
        radius = np.linalg.norm(points - centre - np.outer(along, axis), axis=1).max()
        before = np.pi * radius**2 * (np.ptp(along) + 4 / 3 * radius)
        assert capsule.volume <= before * (1 + 1e-9) + 1e-9
