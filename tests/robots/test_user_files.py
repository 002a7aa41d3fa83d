"""A user's arm as a URDF or a description file; arms that are not serial 6R chains refused."""

import numpy as np
import pytest
import yourdfpy
from robot_files_kit import DESCRIPTION, KUKA, on_a_track, seven_axes, with_geometry

from calibrator import robots
from calibrator.model import kinematics
from calibrator.robots import DescriptionError


def test_capsules_enclose_the_collision_primitives_with_the_stated_margin(tmp_path):
    path = tmp_path / "arm.urdf"
    path.write_text(with_geometry(KUKA))
    arm = robots.get(str(path))
    assert arm.name == str(path)
    assert arm.body.margin_mm == 10.0 and "collision geometry" in arm.body.source
    frames = kinematics.chain(arm.mdh, np.zeros(6), all_frames=True)[1][0]
    caps = {c.name: c for c in arm.body.capsules}

    def inside(capsule, points):
        f = arm.base_offset @ frames[capsule.link]
        p, q = ((f @ np.append(v, 1.0))[:3] for v in (capsule.p_mm, capsule.q_mm))
        t = np.clip((points - p) @ (q - p) / max((q - p) @ (q - p), 1e-12), 0, 1)
        return np.linalg.norm(points - (p + t[:, None] * (q - p)), axis=1)

    # The box on link 2 (at the zero pose, link 2's frame is at (25, 0, 400) mm).
    corners = np.array([[x, y, z] for x in (-250, 250) for y in (-60, 60) for z in (-50, 50)])
    c, s = np.cos(0.3), np.sin(0.3)
    rx = np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    box = corners @ rx.T + [25 + 227.5, 0, 400]
    gap = caps["link_2"].radius_mm - inside(caps["link_2"], box)
    assert gap.min() >= 10.0 - 1e-9 and gap.min() < 10.0 + 1e-6  # tight, plus the margin
    # The cylinder on link 4: its rims; the sphere on link 6.
    rim = np.array(
        [[x, 50 * np.cos(a), 50 * np.sin(a)] for x in (-150, 150) for a in np.linspace(0, 6, 13)]
    )
    cyl = rim + [25 + 455 + 200, 0, 435]
    assert (caps["link_4"].radius_mm - inside(caps["link_4"], cyl)).min() >= 10.0 - 1e-9
    assert caps["link_6"].radius_mm == pytest.approx(50.0)
    # Links without geometry still get a capsule along them.
    assert {c.link for c in arm.body.capsules} == {1, 2, 3, 4, 5, 6}


def test_masses_and_centres_of_mass_come_from_the_inertials(tmp_path):
    path = tmp_path / "arm.urdf"
    path.write_text(with_geometry(KUKA))
    arm = robots.get(str(path))
    np.testing.assert_array_equal(arm.mass_kg, [0, 8, 0, 3, 0, 0])
    # Centre of mass of link 2 in the base frame at the zero pose, by yourdfpy.
    urdf = yourdfpy.URDF.load(str(path), load_meshes=False, build_collision_scene_graph=False)
    link2 = np.array(urdf.get_transform("link_2", "base_link"))
    expected = (link2 @ [0.2, 0, 0.01, 1])[:3] * 1000
    frames = kinematics.chain(arm.mdh, np.zeros(6), all_frames=True)[1][0]
    got = (arm.base_offset @ frames[2] @ np.append(arm.com_mm[1], 1.0))[:3]
    np.testing.assert_allclose(got, expected, atol=1e-9)


def test_links_of_the_chain_can_be_named(tmp_path):
    path = tmp_path / "arm.urdf"
    path.write_text(KUKA)
    to_tool0 = robots.get(f"{path}#base_link:tool0")
    to_flange = robots.get(str(path))  # tool0 is the default tip
    assert to_tool0.name.endswith("#base_link:tool0")
    np.testing.assert_allclose(to_tool0.mdh, to_flange.mdh)
    with pytest.raises(DescriptionError, match="no tip link 'nope'"):
        robots.get(f"{path}#base_link:nope")


@pytest.mark.parametrize(
    ("change", "name", "message"),
    [
        (seven_axes, "arm.urdf", r"7 moving joints .*only serial 6-axis arms .*7-axis"),
        (
            on_a_track,
            "arm.urdf#world:tool0",
            r"joint 'track' is prismatic \(a linear axis or track\)",
        ),
    ],
)
def test_arms_that_are_not_serial_six_axis_chains_are_refused_in_one_line(
    tmp_path, change, name, message
):
    (tmp_path / "arm.urdf").write_text(change(KUKA))
    with pytest.raises(DescriptionError, match=message) as info:
        robots.get(str(tmp_path / name))
    assert "\n" not in str(info.value)


def test_a_description_file_reads_degrees_and_the_controllers_angles(tmp_path):
    path = tmp_path / "arm.yaml"
    path.write_text(DESCRIPTION)
    arm = robots.get(str(path))
    np.testing.assert_allclose(arm.mdh[1], [600, 0, -np.pi / 2, 0, 0])
    # Limits are the controller's: joint 1's sign and joint 2's offset move them.
    np.testing.assert_allclose(np.degrees(arm.joint_limits_rad[:2]), [[-170, 170], [0, 240]])
    assert arm.move_accel_cap_rad_s2 == pytest.approx(np.radians(100))
    np.testing.assert_allclose(
        np.degrees(arm.configurations["upright"]), [0, 0, 0, 0, 0, 0], atol=1e-12
    )
    # The capsule was given in the base frame at the zero pose: link 2's frame moves it.
    cap = arm.body.capsules[0]
    frame = kinematics.chain(arm.mdh, np.zeros(6), all_frames=True)[1][0, 2]
    np.testing.assert_allclose((frame @ np.append(cap.p_mm, 1))[:3], [150, 0, 450], atol=1e-9)
    assert robots.get(str(path)).digest == arm.digest


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (
            lambda t: t.replace("name: test-arm\n", "name: test-arm\nname: again\n"),
            "appears more than once",
        ),
        (lambda t: t.replace("calibrator-robot/1", "calibrator-robot/9"), "format: must be"),
        (lambda t: t + "colour: red\n", "colour: unknown key"),
        (
            lambda t: t.replace("[0, 0, 0, 100, 0]", "[0, 0, 0, 100]"),
            r"mdh: must be numbers, shape \(6, 5\)",
        ),
        (lambda t: t.replace("sign: [-1,", "sign: [2,"), "sign must be six values"),
        (lambda t: t.replace("  lower_deg:", "  lower_deg: [1, 2]\n  x_deg:"), "lower_deg"),
    ],
)
def test_a_bad_description_file_is_refused_naming_what_is_wrong(tmp_path, edit, message):
    path = tmp_path / "arm.yaml"
    path.write_text(edit(DESCRIPTION))
    with pytest.raises(DescriptionError, match=message):
        robots.get(str(path))


def test_the_digest_follows_the_content_not_the_files_name(tmp_path):
    (tmp_path / "a.yaml").write_text(DESCRIPTION)
    (tmp_path / "b.yaml").write_text(DESCRIPTION)
    (tmp_path / "c.yaml").write_text(
        DESCRIPTION.replace("[600, 0, -90, 0, 0]", "[600.001, 0, -90, 0, 0]")
    )
    a, b, c = (robots.get(str(tmp_path / f"{n}.yaml")) for n in "abc")
    assert a.name != b.name and a.digest == b.digest
    assert c.digest != a.digest


def test_a_description_files_masses_are_its_mass_model(tmp_path):
    from calibrator.robots import masses as robot_masses

    path = tmp_path / "arm.yaml"
    masses = "masses:\n  mass_kg: [20, 15, 8, 3, 2, 0.5]\n  com_mm: " + str([[0, 0, 10]] * 6) + "\n"
    path.write_text(DESCRIPTION + masses)
    model = robot_masses.resolve(str(path))
    np.testing.assert_array_equal(model.mass_kg, [20, 15, 8, 3, 2, 0.5])
    np.testing.assert_array_equal(model.com_mm[:, 2], 10.0)


def test_a_collision_mesh_of_the_package_is_enclosed(tmp_path):
    import trimesh

    (tmp_path / "pkg" / "urdf").mkdir(parents=True)
    (tmp_path / "pkg" / "meshes").mkdir()
    mesh = trimesh.creation.box(extents=(0.3, 0.1, 0.08))
    mesh.export(tmp_path / "pkg" / "meshes" / "link_4.stl")
    link_4 = """<link name="link_4">
    <collision><origin xyz="0.2 0 0" rpy="0 0 0.2"/>
      <geometry><mesh filename="package://pkg/meshes/link_4.stl"/></geometry></collision>
  </link>"""
    path = tmp_path / "pkg" / "urdf" / "arm.urdf"
    path.write_text(KUKA.replace('<link name="link_4"/>', link_4))
    arm = robots.get(str(path))
    cap = next(c for c in arm.body.capsules if c.name == "link_4")
    frame = arm.base_offset @ kinematics.chain(arm.mdh, np.zeros(6), all_frames=True)[1][0, 4]
    p, q = ((frame @ np.append(v, 1.0))[:3] for v in (cap.p_mm, cap.q_mm))
    c, s = np.cos(0.2), np.sin(0.2)
    rz = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    corners = np.array([[x, y, z] for x in (-150, 150) for y in (-50, 50) for z in (-40, 40)])
    points = corners @ rz.T + [25 + 455 + 200, 0, 435]  # link_4's frame at the zero pose
    t = np.clip((points - p) @ (q - p) / ((q - p) @ (q - p)), 0, 1)
    distance = np.linalg.norm(points - (p + t[:, None] * (q - p)), axis=1)
    assert distance.max() <= cap.radius_mm - 10.0 + 1e-9  # enclosed, margin on top
    assert cap.radius_mm - 10.0 < 70.0  # and not a blob: the box's half cross-diagonal is 64


def test_a_changed_file_is_read_again(tmp_path):
    path = tmp_path / "arm.urdf"
    path.write_text(KUKA)
    first = robots.get(str(path))
    assert robots.get(str(path)).digest == first.digest
    assert robots.get(str(path)).mdh is not first.mdh  # each caller its own arrays
    path.write_text(KUKA.replace('xyz="0.455 0 0"', 'xyz="0.5 0 0"'))
    assert robots.get(str(path)).mdh[1, 0] == pytest.approx(500.0)
