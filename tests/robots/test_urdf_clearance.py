"""Link pairs the capsule check skips (their capsules overlap at zero) get their joint narrowed.

A wrist fork's capsule holds the flange's at the zero pose, so the cell's
self-collision check never compares them; folded far enough, the real flange
runs into the forearm's end. Reading the URDF sweeps the two meshes over
joint 5 (joint 6 at any angle) and narrows joint 5 to where they keep the
fit margin; another URDF reader and the meshes' own surface points agree.
"""

import numpy as np
import pytest
import trimesh
import yourdfpy
from scipy.spatial import cKDTree
from urdf_mesh_kit import along_moves, arm_with_meshes, box, housings, planned, posed_mm

from calibrator.robots import clearance, urdf

#: Axis 5 of the KUKA URDF in link_4's frame (m): joint a5's origin.
AXIS_5_X = 0.42
#: The forearm's end face this far behind axis 5 (m): the flange, 0.07 to 0.08 m
#: out and 0.04 m to each side, reaches it folded back past about 100 degrees.
END = 0.07


def _forked():
    """The KUKA housings with link_4 a forearm ending in a fork whose cheeks clear the flange."""
    meshes = housings()
    end = AXIS_5_X - END
    meshes["link_4"] = trimesh.util.concatenate(
        [
            box((-0.05, -0.05, -0.05), (end, 0.05, 0.05)),
            box((end, 0.07, -0.05), (AXIS_5_X + 0.05, 0.09, 0.05)),
            box((end, -0.09, -0.05), (AXIS_5_X + 0.05, -0.07, 0.05)),
        ]
    )
    return meshes


def _gap(path, meshes, q5_deg):
    """Least distance of link_4's and link_6's surface points, joint 6 all round (mm)."""
    model = yourdfpy.URDF.load(str(path), load_meshes=False, build_collision_scene_graph=False)
    points = {k: trimesh.sample.sample_surface(meshes[k], 4000, seed=1)[0] for k in meshes}
    least = np.inf
    for q6 in np.radians(np.arange(0.0, 360.0, 5.0)):
        model.update_cfg({"joint_a5": np.radians(q5_deg), "joint_a6": q6})
        placed = posed_mm(model, {name: points[name] for name in ("link_4", "link_6")})
        least = min(least, cKDTree(placed["link_4"]).query(placed["link_6"])[0].min())
    return least


def test_a_flange_folding_into_the_forearm_narrows_joint_5_to_where_it_keeps_the_margin(tmp_path):
    meshes = _forked()
    path = arm_with_meshes(tmp_path, meshes)
    arm = urdf.describe(path)
    lo, hi = np.degrees(arm.joint_limits_rad[4])
    # The URDF's joint 5 limits are +-120 deg; folded that far the flange is in the forearm.
    assert _gap(path, meshes, 120.0) < 0.5 * urdf.FIT_MARGIN_MM
    assert -120.0 < lo < -60.0 and 60.0 < hi < 120.0
    # At the narrowed limits the surfaces keep the margin (less the sampling's
    # few mm), and not much more: the sweep stops where the margin runs out.
    for end in (lo, hi):
        gap = _gap(path, meshes, end)
        assert urdf.FIT_MARGIN_MM - 3.0 < gap < urdf.FIT_MARGIN_MM + 6.0, (end, gap)
    # Only joint 5 changes (the others are the URDF's), and the description says why.
    others = np.delete(np.degrees(arm.joint_limits_rad), 4, axis=0)
    assert np.allclose(others, [[-170, 170], [-190, 45], [-120, 156], [-185, 185], [-350, 350]])
    (note,) = [n for n in arm.limit_notes if n.startswith("joint 5")]
    assert note.startswith(f"joint 5 limited to [{lo:.1f}, {hi:.1f}] deg from [-120.0, 120.0]")
    assert "link_4 and link_6" in note


def test_a_plan_for_the_forked_arm_keeps_the_flange_out_of_the_forearm(tmp_path):
    meshes = _forked()
    path, stderr, plan = planned(tmp_path, meshes)
    assert "note: joint 5 limited to [" in stderr
    # Independently, along every move: the real surfaces of link_4 and link_6 posed
    # by another URDF reader stay apart.
    model = yourdfpy.URDF.load(str(path), load_meshes=False, build_collision_scene_graph=False)
    points = {k: trimesh.sample.sample_surface(meshes[k], 3000, seed=0)[0] for k in meshes}
    names = [f"joint_a{i}" for i in range(1, 7)]
    sign = np.array(urdf.describe(path).convention.sign)
    closest = np.inf
    for q in along_moves(plan.path_rad):
        model.update_cfg(dict(zip(names, q * sign, strict=True)))
        placed = posed_mm(model, {name: points[name] for name in ("link_4", "link_6")})
        closest = min(closest, cKDTree(placed["link_4"]).query(placed["link_6"])[0].min())
    assert closest > 0.0


def test_the_sweep_keeps_the_margin_between_its_samples_and_is_the_same_every_run():
    # Two unit-spaced point rods on joint axes: a far rod swinging about the
    # middle joint's axis into a near rod, whatever the far joint's angle.
    rod = np.column_stack([np.linspace(0.0, 100.0, 101), np.zeros(101), np.zeros(101)])
    near = clearance.Link(rod + [0.0, 0.0, -50.0], np.eye(4), np.array([0.0, 0.0, 1.0]), (-1, 1))
    middle = clearance.Link(np.zeros((1, 3)), np.eye(4), np.array([0.0, 0.0, 1.0]), (-3.0, 3.0))
    far = clearance.Link(rod, np.eye(4), np.array([1.0, 0.0, 0.0]), (-3.0, 3.0))
    found = clearance.sweep(near, middle, far, 10.0)
    assert found == clearance.sweep(near, middle, far, 10.0)
    assert found is not None and found.joint in (1, 2)
    assert found.interval[0] <= 0.0 <= found.interval[1]


@pytest.mark.parametrize("spacing", [5.0, 20.0])
def test_surface_points_cover_a_face_at_the_spacing_asked_and_repeat(spacing):
    mesh = box((0, 0, 0), (100, 100, 1))
    first = clearance.surface_points(mesh.vertices, mesh.faces, spacing)
    assert np.array_equal(first, clearance.surface_points(mesh.vertices, mesh.faces, spacing))
    assert len(first) >= 8 + 2 * 100 * 100 / spacing**2
