"""A sweep narrowing a reversed joint with asymmetric limits: the URDF's sides, then the model's.

KUKA's A6 turns about -x in its URDF: the model angle is minus the URDF's,
so the sweep (in URDF angles) must be given the URDF's limits and its
interval mirrored back. Every swept joint of the other test arms is
symmetric or not reversed, where a limit or interval taken the wrong way
round gives the same numbers. Here a one-sided wrist (one prong past
axis 5) and a flange with a lug: turned half a turn about axis 6 the lug
reaches the prong, so joint 6 is narrowed on the side of the URDF's
upper limit only (the lug is tilted, so turning the other way would not
narrow it); its limits (-2, 3) rad are asymmetric, so the walk stops
short of the URDF's upper limit (3) and reaches its lower one (-2).
"""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
import yourdfpy
from scipy.spatial import cKDTree
from urdf_mesh_kit import arm_with_meshes, box, housings, posed_mm

from calibrator.robots import urdf

#: URDF limits of joint_a6 (rad), made asymmetric; the model's are (-3, 2).
A6 = (-2.0, 3.0)
SHIPPED_A6 = 'lower="-6.1086523819801535" upper="6.1086523819801535"'


def _meshes():
    """A forearm with one prong beside axis 5 (y 70-90 mm) and a flange with a 65 mm lug."""
    meshes = housings()
    meshes["link_4"] = trimesh.util.concatenate(
        [
            box((-0.05, -0.05, -0.05), (0.22, 0.05, 0.05)),
            box((0.17, 0.05, -0.05), (0.22, 0.09, 0.05)),
            # The prong ends 20 mm short of the flange's plane (link_4 x = 0.5): with
            # joint 6 at any angle the lug's circle lets joint 5 turn +-23 deg, a smaller
            # share of its range than joint 6 keeps (86 %): joint 6 is the one narrowed.
            box((0.17, 0.07, -0.05), (0.47, 0.09, 0.05)),
        ]
    )
    meshes["link_6"] = trimesh.util.concatenate(
        [
            box((-0.01, -0.03, -0.03), (0.0, 0.03, 0.03)),
            _lug(),
        ]
    )
    return meshes


def _lug():
    """A 65 mm lug on the flange (link_6 frame, m), at zero along -y tilted 20 deg to +z.

    Joint 6 turned by 160 deg (URDF, about -x) points it at the prong (5 mm
    off), by -160 deg not: the sweep's sense of turning matters, not only
    which side of its interval is which.
    """
    lug = box((-0.01, -0.065, -0.005), (0.0, 0.0, 0.005))
    lug.apply_transform(trimesh.transformations.rotation_matrix(np.radians(-20.0), (1, 0, 0)))
    return lug


@pytest.fixture(scope="module")
def arm(tmp_path_factory):
    folder = tmp_path_factory.mktemp("reversed")
    meshes = _meshes()
    path = arm_with_meshes(folder, meshes)
    text = path.read_text()
    assert text.count(SHIPPED_A6) == 1
    path.write_text(text.replace(SHIPPED_A6, f'lower="{A6[0]}" upper="{A6[1]}"'))
    return path, meshes, urdf.describe(path)


def _least_gaps_mm(path, meshes, q6s_urdf):
    """Least distance of link_4's and link_6's surface points, joint 5 all round, per q6 (mm)."""
    model = yourdfpy.URDF.load(str(path), load_meshes=False, build_collision_scene_graph=False)
    points = {k: trimesh.sample.sample_surface(meshes[k], 3000, seed=2)[0] for k in meshes}
    tree = cKDTree(posed_mm(model, {"link_4": points["link_4"]})["link_4"])  # joint 5 keeps it
    out = []
    for q6 in q6s_urdf:
        least = np.inf
        for q5 in np.radians(np.arange(-180.0, 180.0, 3.0)):
            model.update_cfg({"joint_a5": q5, "joint_a6": q6})
            at = posed_mm(model, {"link_6": points["link_6"]})["link_6"]
            least = min(least, tree.query(at, distance_upper_bound=50.0)[0].min())
        out.append(least)
    return out


def test_joint_6_is_narrowed_on_its_urdf_upper_side_and_keeps_its_lower_limit(arm):
    path, meshes, described = arm
    assert described.convention.sign[5] == -1.0  # reversed: model = -URDF
    lo, hi = described.joint_limits_rad[5]
    # The model's upper end is the URDF's lower limit, not narrowed: nothing is there.
    assert hi == pytest.approx(-A6[0], abs=1e-12)
    # The model's lower end is the URDF's upper side, narrowed short of the limit (3 rad,
    # 172 deg): the lug comes within 5 mm of the prong at 160 deg, within 10 from 137 or so.
    assert np.radians(-140.0) < lo < np.radians(-125.0), np.degrees(lo)
    # Joint 5, which the prong stops at +-23 deg with joint 6 free, is not narrowed.
    np.testing.assert_allclose(described.joint_limits_rad[4], np.radians([-120.0, 120.0]))
    # One note per joined pair of links two apart, none for neighbours (they always touch).
    pair_2_4, note = described.limit_notes
    assert pair_2_4 == (
        "links link_2 and link_4 come within 10 mm of each other at zero (joints 3 and 4 at "
        "any angle): not narrowed, their clearance is not checked"
    )
    assert note.startswith(
        f"joint 6 limited to [{np.degrees(lo):.1f}, {np.degrees(hi):.1f}] deg "
        f"from [{np.degrees(-A6[1]):.1f}, {np.degrees(-A6[0]):.1f}]: beyond it the meshes of "
        "links link_4 and link_6 come within 10 mm (joint 5 at any angle"
    ), note


def test_at_the_narrowed_end_the_meshes_keep_the_margin_and_past_it_they_do_not(arm):
    """yourdfpy, another URDF reader, poses the links: the end is where the margin is."""
    path, meshes, described = arm
    end_urdf = -described.joint_limits_rad[5, 0]  # the URDF angle of the narrowed end
    at_end, past_end, at_lower = _least_gaps_mm(
        path, meshes, [end_urdf, end_urdf + np.radians(4.0), A6[0]]
    )
    assert urdf.FIT_MARGIN_MM - 3.0 < at_end < urdf.FIT_MARGIN_MM + 4.0, at_end
    assert past_end < urdf.FIT_MARGIN_MM
    # At the URDF's lower limit, the model's upper end, the lug is far from the prong.
    assert at_lower > urdf.FIT_MARGIN_MM + 20.0


def test_a_lug_at_the_prong_at_zero_leaves_joint_5_too_little_and_is_said_not_narrowed(tmp_path):
    """Turned half a turn, the lug sits 5 mm from the prong at zero: joint 6 has no interval,
    joint 5 keeps +-23 deg of +-120 (under half): neither is narrowed, and the note says so."""
    meshes = _meshes()
    lug = _lug()
    lug.apply_transform(trimesh.transformations.rotation_matrix(np.pi, (1, 0, 0)))
    meshes["link_6"] = trimesh.util.concatenate(
        [box((-0.01, -0.03, -0.03), (0.0, 0.03, 0.03)), lug]
    )
    path = arm_with_meshes(tmp_path, meshes)
    path.write_text(path.read_text().replace(SHIPPED_A6, f'lower="{A6[0]}" upper="{A6[1]}"'))
    described = urdf.describe(path)
    np.testing.assert_allclose(described.joint_limits_rad[4], np.radians([-120.0, 120.0]))
    np.testing.assert_allclose(described.joint_limits_rad[5], [-A6[1], -A6[0]])
    note = described.limit_notes[1]
    assert note.startswith(
        "links link_4 and link_6: with joint 6 at any angle their meshes keep 10 mm only for "
        "joint 5 in [-2"
    ), note
    assert note.endswith(
        "deg, under 50% of its range: not narrowed, their clearance is not checked"
    )
