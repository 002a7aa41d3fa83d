"""Descriptions that would disable a check are refused where they are read, naming the field.

Every field is held to its physical meaning: radii positive, offsets rigid,
named configurations inside the limits, couplings between joints 1 to 6,
link names that are names, URDF lengths in metres and limits in radians,
meshes that can be read and whose scale allocates nothing absurd.
"""

import time

import numpy as np
import pytest
from cli_kit import cli, one_line_error
from robot_files_kit import DESCRIPTION, KUKA, with_geometry

from calibrator import robots
from calibrator.robots import DescriptionError

RIGID_SCALED = "[[2, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]"


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda t: t.replace("radius_mm: 90}", "radius_mm: -90}"), r"radius_mm: must be > 0"),
        (lambda t: t.replace("radius_mm: 90}", "radius_mm: 0}"), r"radius_mm: must be > 0"),
        (lambda t: t.replace("base_radius_mm: 120", "base_radius_mm: -120"), "base_radius_mm"),
        (
            lambda t: t.replace("  base_top_mm: 320", "  base_top_mm: 320\n  margin_mm: -5"),
            "margin",
        ),
        (
            lambda t: t.replace(
                "    - [0, 0, 0, 100, 0]\n",
                f"    - [0, 0, 0, 100, 0]\n  base_offset: {RIGID_SCALED}\n",
            ),
            "base_offset: must be a rigid transform",
        ),
        (
            lambda t: t.replace(
                "    - [0, 0, 0, 100, 0]\n",
                "    - [0, 0, 0, 100, 0]\n  flange_offset: "
                "[[0, 1, 0, 0], [1, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]\n",
            ),
            "flange_offset: must be a rigid transform",
        ),
        (
            lambda t: t.replace("home: [0, 0, 0, 0, 0, 0]", "home: [0, 0, 0, 0, 170, 0]"),
            r"arm\.yaml: robot .*: configuration 'home' has joint 5 at 170 deg, outside",
        ),
        (
            lambda t: t.replace(
                "  source: typed for a test\nbody",
                "  couplings: [{joint: 9, from: 2, factor: 1}]\n  source: typed for a test\nbody",
            ),
            r"couplings\[0\]: joint: 9: joints are numbered 1 to 6",
        ),
        (
            lambda t: t.replace(
                "  source: typed for a test\nbody",
                "  couplings: [{joint: 2, from: 3, factor: 1}]\n  source: typed for a test\nbody",
            ),
            r"couplings\[0\]: from: a joint is coupled to an earlier joint",
        ),
    ],
)
def test_a_description_field_against_its_meaning_is_refused(tmp_path, edit, message):
    path = tmp_path / "arm.yaml"
    text = edit(DESCRIPTION)
    assert text != DESCRIPTION
    path.write_text(text)
    with pytest.raises(DescriptionError, match=message):
        robots.get(str(path))


def _urdf_description(
    tmp_path, urdf_text, kinematics_extra="", body="  link_radius_mm: [80, 80, 70, 60, 50, 40]\n"
):
    (tmp_path / "arm.urdf").write_text(urdf_text)
    path = tmp_path / "arm.yaml"
    path.write_text(
        "format: calibrator-robot/1\nname: urdf-arm\nsource: a test\n"
        f"kinematics:\n  urdf: arm.urdf\n{kinematics_extra}"
        f"body:\n{body}"
    )
    return path


def test_a_tip_link_that_is_no_name_is_refused_in_one_line(tmp_path):
    path = _urdf_description(tmp_path, KUKA, "  tip_link: [link_6, tool0]\n")
    with pytest.raises(DescriptionError, match="tip_link: must be a non-empty text"):
        robots.get(str(path))


def test_negative_link_radii_of_a_urdf_description_are_refused(tmp_path):
    path = _urdf_description(
        tmp_path, KUKA, body="  margin_mm: 10\n  link_radius_mm: [80, 80, -5, 60, 50, 40]\n"
    )
    with pytest.raises(DescriptionError, match=r"link_radius_mm: must be > 0"):
        robots.get(str(path))


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (
            lambda t: t.replace('<sphere radius="0.04"/>', '<sphere radius="-0.5"/>'),
            r"sphere: radius '-0.5' must be > 0",
        ),
        (
            lambda t: t.replace('radius="0.05" length="0.3"', 'radius="0.05" length="0"'),
            r"cylinder: length '0' must be > 0",
        ),
        (
            lambda t: t.replace('<box size="0.5 0.12 0.1"/>', '<box size="500 120 100"/>'),
            "written in millimetres",
        ),
    ],
)
def test_urdf_shapes_of_no_or_negative_size_are_refused(tmp_path, edit, message):
    text = edit(with_geometry(KUKA))
    (tmp_path / "arm.urdf").write_text(text)
    with pytest.raises(DescriptionError, match=message):
        robots.get(str(tmp_path / "arm.urdf"))


def test_a_shape_thinner_than_a_millimetre_is_a_shape(tmp_path):
    """A cover plate 0.5 mm thick is positive (metres in the file), not refused as no size."""
    text = with_geometry(KUKA).replace(
        '<box size="0.5 0.12 0.1"/>', '<box size="0.5 0.12 0.0005"/>'
    )
    (tmp_path / "arm.urdf").write_text(text)
    arm = robots.get(str(tmp_path / "arm.urdf"))
    (capsule,) = [c for c in arm.body.capsules if c.name == "link_2"]
    # Half the plate's 120 mm width and 0.5 mm thickness across, plus the 10 mm margin.
    assert capsule.radius_mm == pytest.approx(np.hypot(60.0, 0.25) + 10.0, abs=1e-6)


def _in_millimetres(text):
    """The KUKA URDF with its joint origins in millimetres."""
    import re

    def mm(m):
        values = " ".join(f"{float(v) * 1000:g}" for v in m.group(1).split())
        return f'origin xyz="{values}"'

    return re.sub(r'origin xyz="([^"]*)"', mm, text)


def test_a_urdf_in_millimetres_is_refused_when_read_by_any_command(tmp_path):
    (tmp_path / "arm.urdf").write_text(_in_millimetres(KUKA))
    with pytest.raises(DescriptionError, match="written in millimetres"):
        robots.get(str(tmp_path / "arm.urdf"))
    line = one_line_error(cli("simulate", "--model", "arm.urdf", "-o", "s.parquet", cwd=tmp_path))
    assert "written in millimetres? URDF lengths are metres" in line
    assert not (tmp_path / "s.parquet").exists()


def test_urdf_limits_written_in_degrees_are_refused(tmp_path):
    text = KUKA.replace(
        'lower="-2.9670597283903604" upper="2.9670597283903604"', 'lower="-170" upper="170"'
    )
    assert text != KUKA
    (tmp_path / "arm.urdf").write_text(text)
    with pytest.raises(DescriptionError, match="written in degrees"):
        robots.get(str(tmp_path / "arm.urdf"))


def _with_mesh(tmp_path, mesh_bytes=None, scale=None):
    import trimesh

    (tmp_path / "pkg" / "urdf").mkdir(parents=True)
    (tmp_path / "pkg" / "meshes").mkdir()
    stl = tmp_path / "pkg" / "meshes" / "link_4.stl"
    if mesh_bytes is None:
        trimesh.creation.box(extents=(0.3, 0.1, 0.08)).export(stl)
    else:
        stl.write_bytes(mesh_bytes)
    scaled = f' scale="{scale}"' if scale else ""
    link_4 = f"""<link name="link_4">
    <collision><origin xyz="0.2 0 0" rpy="0 0 0.2"/>
      <geometry><mesh filename="package://pkg/meshes/link_4.stl"{scaled}/></geometry></collision>
  </link>"""
    path = tmp_path / "pkg" / "urdf" / "arm.urdf"
    path.write_text(KUKA.replace('<link name="link_4"/>', link_4))
    return path


def test_an_unreadable_mesh_is_named_not_dropped(tmp_path):
    path = _with_mesh(tmp_path, mesh_bytes=b"solid nothing\nendsolid nothing\n")
    with pytest.raises(
        DescriptionError, match=r"link 'link_4' collision: mesh link_4\.stl holds no triangles"
    ):
        robots.get(str(path))


@pytest.mark.parametrize("scale", ["300 300 300", "1e6 1e6 1e6", "1e308 1e308 1e308"])
def test_a_huge_mesh_scale_is_refused_at_once_without_allocating(tmp_path, scale):
    import resource

    path = _with_mesh(tmp_path, scale=scale)
    start = time.monotonic()
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    with pytest.raises(DescriptionError, match=r"mesh link_4\.stl spans .* m once scaled"):
        robots.get(str(path))
    assert time.monotonic() - start < 10
    grown_kib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before
    assert grown_kib < 200_000, grown_kib  # not the gigabytes the surface sampling took


def test_a_mesh_scaled_from_millimetres_is_read(tmp_path):
    import trimesh

    path = _with_mesh(tmp_path, scale="0.001 0.001 0.001")
    trimesh.creation.box(extents=(300, 100, 80)).export(
        path.parent.parent / "meshes" / "link_4.stl"
    )
    arm = robots.get(str(path))
    cap = next(c for c in arm.body.capsules if c.name == "link_4")
    assert 50 < cap.radius_mm - 10.0 < 70.0
    assert np.isfinite(cap.radius_mm)


def test_an_origin_beyond_any_arm_is_refused_before_it_overflows(tmp_path):
    import warnings

    text = KUKA.replace('origin xyz="0 0 0.4"', 'origin xyz="1e308 0 0.4"')
    assert text != KUKA
    (tmp_path / "arm.urdf").write_text(text)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no overflow on the way to the refusal
        with pytest.raises(DescriptionError, match=r"origin xyz '1e308 0 0.4' is beyond 10 m"):
            robots.get(str(tmp_path / "arm.urdf"))


def test_a_mesh_of_folded_faces_asking_for_billions_of_points_is_refused(tmp_path):
    import trimesh

    # 20,000 copies of one 1 m x 1 m square, all within a 1 m extent: 20,000 m^2
    # of surface the clearance sweep would sample every 10 mm (2e8 points).
    square = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], [[0, 1, 2], [0, 2, 3]])
    folded = trimesh.Trimesh(
        np.tile(square.vertices, (20_000, 1))
        + np.repeat(np.arange(20_000), 4)[:, None] * [0, 0, 1e-5],
        np.concatenate([square.faces + 4 * k for k in range(20_000)]),
        process=False,
    )
    path = _with_mesh(tmp_path)
    folded.export(path.parent.parent / "meshes" / "link_4.stl")
    start = time.monotonic()
    with pytest.raises(DescriptionError, match=r"link_4\.stl has .* m\^2 of surface once scaled"):
        robots.get(str(path))
    assert time.monotonic() - start < 20


def test_counts_a_description_file_can_ask_for_are_bounded(tmp_path):
    capsule = "    - {name: c, link: 2, p_mm: [150, 0, 450], q_mm: [750, 0, 450], radius_mm: 90}\n"
    text = DESCRIPTION.replace(capsule.replace("name: c", "name: upper arm"), capsule * 65)
    assert text != DESCRIPTION
    (tmp_path / "arm.yaml").write_text(text)
    with pytest.raises(DescriptionError, match="capsules: 65 listed, at most 64"):
        robots.get(str(tmp_path / "arm.yaml"))
    many = "".join(f"  c{k}: [0, 0, 0, 0, 0, 0]\n" for k in range(65))
    (tmp_path / "arm.yaml").write_text(
        DESCRIPTION.replace(
            "  upright: [0, -90, 0, 0, 0, 0]\n", "  upright: [0, -90, 0, 0, 0, 0]\n" + many
        )
    )
    with pytest.raises(DescriptionError, match="configurations: more than 64 named"):
        robots.get(str(tmp_path / "arm.yaml"))
