"""A URDF read at the edges of what it may say: two turns, a mesh in millimetres, a lying base.

A limit of exactly two turns each way is an arm's (beyond it: degrees);
a mesh too large once scaled is refused with the scale that reads it in
millimetres; a base cylinder lying on its side stands on its lowest rim.
"""

from __future__ import annotations

import numpy as np
import pytest
from robot_files_kit import KUKA

from calibrator import robots
from calibrator.robots import DescriptionError

A6 = 'lower="-6.1086523819801535" upper="6.1086523819801535"'


def test_a_limit_of_exactly_two_turns_each_way_is_read(tmp_path):
    turns = 4 * np.pi
    (tmp_path / "arm.urdf").write_text(KUKA.replace(A6, f'lower="{-turns!r}" upper="{turns!r}"'))
    arm = robots.get(str(tmp_path / "arm.urdf"))
    np.testing.assert_array_equal(arm.joint_limits_rad[5], [-turns, turns])
    (tmp_path / "past.urdf").write_text(KUKA.replace(A6, 'lower="-12.57" upper="12.57"'))
    with pytest.raises(DescriptionError, match="more than two turns: written in degrees"):
        robots.get(str(tmp_path / "past.urdf"))


def test_a_mesh_too_large_once_scaled_is_refused_with_the_millimetre_scale(tmp_path):
    import trimesh

    (tmp_path / "pkg" / "urdf").mkdir(parents=True)
    (tmp_path / "pkg" / "meshes").mkdir()
    trimesh.creation.box(extents=(300, 100, 80)).export(tmp_path / "pkg" / "meshes" / "link_4.stl")
    link_4 = (
        '<link name="link_4"><collision><geometry><mesh filename="package://pkg/meshes/'
        'link_4.stl"/></geometry></collision></link>'
    )
    path = tmp_path / "pkg" / "urdf" / "arm.urdf"
    path.write_text(KUKA.replace('<link name="link_4"/>', link_4))
    with pytest.raises(DescriptionError) as refused:
        robots.get(str(path))
    assert str(refused.value).endswith(
        "mesh link_4.stl spans 300 m once scaled: no arm link's (URDF meshes are metres; "
        'a mesh in millimetres needs scale="0.001 0.001 0.001")'
    )


def _base(tmp_path, name, geometry, origin):
    base = (
        f'<link name="base_link"><collision><origin xyz="{origin}"/>'
        f"<geometry>{geometry}</geometry></collision></link>"
    )
    (tmp_path / name).write_text(KUKA.replace('<link name="base_link"/>', base))
    return robots.get(str(tmp_path / name))


@pytest.mark.parametrize("roll", ["1.5707963267948966", "-1.5707963267948966"])
def test_a_base_cylinder_lying_on_its_side_stands_on_its_lowest_rim(tmp_path, roll):
    lying = _base(
        tmp_path,
        "lying.urdf",
        '<cylinder radius="0.1" length="0.3"/>',
        f'0 0 0.1" rpy="{roll} 0 0',
    )
    boxed = _base(tmp_path, "box.urdf", '<box size="0.3 0.2 0.2"/>', "0 0 0.1")
    # Both reach down to the base link's z = 0: the same mounting plane, the rims' 72-gons
    # drawn round the circles (so no point of a rim is lower) lower it by 0.1 mm at most.
    assert 0.0 <= boxed.body.mount_z_mm - lying.body.mount_z_mm < 0.1
