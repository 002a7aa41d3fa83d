"""The controller's base (world) frame and flange (tool 0) in the description.

The shipped arms take them from ROS-Industrial's ``base`` and ``tool0``
links (the REP-199 draft): checked here against yourdfpy's reading of the
shipped URDFs and against the numbers the issue quotes (ABB's tool0 at
all-zero axes is the quaternion [0.7071, 0, 0.7071, 0]; FANUC's World is
525 mm above base_link on the M-20iA). A URDF user gets them from the same
link names, from a ``base`` link named with ``--base-link`` that is not above
the tip (FANUC's hangs beside the chain), or from a description file's
``frames:`` section.
"""

from pathlib import Path

import numpy as np
import pytest
import yourdfpy

from calibrator import robots
from calibrator.model import kinematics, rotations
from calibrator.robots import DescriptionError

DATA = Path(robots.__file__).with_name("data")
ARMS = ("kuka-kr6-r900", "abb-irb4600-60-205", "fanuc-m20ia", "yaskawa-gp8", "staubli-tx2-60")


def pendant(arm, q_ctrl):
    """tool0 in the controller's base frame by the description (mm), (N, 4, 4)."""
    q = arm.convention.to_model(q_ctrl)
    return (
        np.linalg.inv(arm.model_base2controller_base)
        @ kinematics.chain(arm.mdh, q)
        @ arm.model_flange2controller_flange
    )


def yourdfpy_base_to_tool0(path, q_urdf):
    model = yourdfpy.URDF.load(str(path), load_meshes=False, build_collision_scene_graph=False)
    out = []
    for q in q_urdf:
        model.update_cfg(dict(zip(model.actuated_joint_names, q, strict=True)))
        t = np.array(model.get_transform("tool0", "base"))
        t[:3, 3] *= 1000.0
        out.append(t)
    return np.array(out)


def test_abb_tool0_at_all_zero_axes_is_the_quaternion_abb_states():
    arm = robots.get("abb-irb4600-60-205")
    pose = pendant(arm, np.zeros((1, 6)))[0]
    quat = rotations.matrix_to_quaternion(pose[None, :3, :3], [[1.0, 0.0, 0.0, 0.0]])[0]
    np.testing.assert_allclose(quat, [np.sqrt(0.5), 0.0, np.sqrt(0.5), 0.0], atol=1e-12)
    # x = 175 + 960 + 135 mm out, z = 495 + 900 + 175 mm up: the product data's wrist.
    np.testing.assert_allclose(pose[:3, 3], [1270.0, 0.0, 1570.0], atol=1e-9)


def test_fanuc_world_sits_at_j2_height():
    arm = robots.get("fanuc-m20ia")
    np.testing.assert_allclose(arm.base2controller_base[:3, 3], [0.0, 0.0, 525.0], atol=1e-12)
    pose = pendant(arm, np.zeros((1, 6)))[0]
    # At all-zero axes the faceplate is 150 + 835 + 100 mm out and 790 + 250 mm above J2.
    np.testing.assert_allclose(pose[:3, 3], [1085.0, 0.0, 1040.0], atol=1e-9)
    assert "World" in arm.controller_base_source and "m20ia_macro.xacro" in (
        arm.controller_base_source
    )


@pytest.mark.parametrize("name", ARMS)
def test_the_frames_are_the_urdfs_base_and_tool0(name):
    arm = robots.get(name)
    rng = np.random.default_rng(3)
    q_model = rng.uniform(arm.joint_limits_rad[:, 0], arm.joint_limits_rad[:, 1], (50, 6))
    q_ctrl = arm.convention.to_controller(q_model)
    q_urdf = q_ctrl.copy()
    if name == "fanuc-m20ia":  # fanuc_driver: J3 of the URDF = J3 + J2 of the controller
        q_urdf[:, 2] += q_urdf[:, 1]
    expected = yourdfpy_base_to_tool0(DATA / f"{name}.urdf", q_urdf)
    assert np.abs(pendant(arm, q_ctrl) - expected).max() < 1e-9
    assert "ros-industrial/" in arm.controller_base_source
    assert "ros-industrial/" in arm.controller_flange_source


@pytest.mark.parametrize("name", ["ur5e", "ur10", "ur10e"])
def test_a_ur_base_and_tool_flange_are_its_dh_frames(name):
    arm = robots.get(name)
    assert not arm.has_controller_frames
    assert "180 deg about z" in arm.controller_base_source
    assert "tool0" in arm.controller_flange_source
    # Identity frames leave the canonical content, and the digest, as they were.
    assert "controller_frames" not in arm.as_dict()


def test_a_plain_urdf_takes_rep199_links_and_a_sibling_base_link(tmp_path):
    path = tmp_path / "m20ia.urdf"
    path.write_text((DATA / "fanuc-m20ia.urdf").read_text())
    plain = robots.get(str(path))  # chain base_link to tool0
    assert "link 'base'" in plain.controller_base_source
    np.testing.assert_allclose(plain.base2controller_base[:3, 3], [0, 0, 525], atol=1e-12)
    np.testing.assert_array_equal(plain.flange2controller_flange, np.eye(4))
    # FANUC's base hangs off base_link, beside the chain: named as the base link,
    # the chain still starts at base_link and `base` is the controller's base.
    named = robots.get(str(path), base_link="base")
    assert named.name == f"{path}#base:" and "named as the base link" in (
        named.controller_base_source
    )
    np.testing.assert_allclose(named.base2controller_base, plain.base2controller_base)
    np.testing.assert_allclose(named.mdh, plain.mdh)
    assert robots.get(named.name).digest == named.digest


def test_a_base_link_that_is_not_fixed_to_the_chain_is_still_refused(tmp_path):
    sensor = (
        '<link name="sensor"/><joint name="link_2-sensor" type="fixed">'
        '<parent link="link_2"/><child link="sensor"/></joint></robot>'
    )
    path = tmp_path / "m20ia.urdf"
    path.write_text((DATA / "fanuc-m20ia.urdf").read_text().replace("</robot>", sensor))
    # Fixed to link 2, which joints 1 and 2 move: not a frame of the base.
    with pytest.raises(DescriptionError, match="link 'tool0' is not below 'sensor'"):
        robots.get(str(path), base_link="sensor")


def _file(tmp_path, frames):
    (tmp_path / "arm.urdf").write_text((DATA / "fanuc-m20ia.urdf").read_text())
    path = tmp_path / "arm.yaml"
    path.write_text(
        "format: calibrator-robot/1\nname: my-m20ia\nsource: a test\n"
        "kinematics:\n  urdf: arm.urdf\n  tip_link: flange\n"
        "body:\n  margin_mm: 10\n  base_radius_mm: 200\n  base_top_mm: 300\n"
        "  link_radius_mm: [90, 80, 70, 60, 50, 40]\n" + frames
    )
    return str(path)


def test_a_description_file_names_the_frames_by_link_or_numbers(tmp_path):
    by_link = robots.get(
        _file(
            tmp_path,
            "frames:\n  base: {link: base, source: our cell's World}\n"
            "  flange: {link: tool0, source: the faceplate}\n",
        )  # fmt: skip
    )
    assert by_link.controller_base_source == "our cell's World"
    by_numbers = robots.get(
        _file(
            tmp_path,
            "frames:\n  base: {xyz_mm: [0, 0, 525], rpy_deg: [0, 0, 0], source: s}\n"
            "  flange: {xyz_mm: [0, 0, 0], rpy_deg: [180, -90, 0], source: s}\n",
        )  # fmt: skip
    )
    np.testing.assert_allclose(by_numbers.base2controller_base, by_link.base2controller_base)
    np.testing.assert_allclose(
        by_numbers.flange2controller_flange, by_link.flange2controller_flange, atol=1e-12
    )
    turned = np.array([[0, -1, 0, 5], [1, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], float)
    by_matrix = robots.get(
        _file(tmp_path, f"frames:\n  base: {{matrix_mm: {turned.tolist()}, source: s}}\n")
    )
    np.testing.assert_array_equal(by_matrix.base2controller_base, turned)
    assert by_matrix.digest != by_link.digest


@pytest.mark.parametrize(
    "frames, says",
    [
        ("  base: {link: link_3, source: s}\n",
         "base: link: 'link_3' is not a link fixed to the chain's base ('base_link')"),
        ("  flange: {link: base, source: s}\n",
         "flange: link: 'base' is not a link fixed to the chain's flange ('flange')"),
        ("  base: {matrix_mm: [[2,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]], source: s}\n",
         "matrix_mm: matrix_mm rotation part is not a proper rotation"),
        ("  base: {link: base}\n", "base: source: must be a non-empty text"),
        ("  base: {link: base, xyz_mm: [0, 0, 0], source: s}\n", "give exactly one of"),
        ("  world: {link: base, source: s}\n", "frames: world: unknown key"),
        ("  base: {xyz_mm: [0, 0, 1], source: s}\n", "rpy_deg: missing"),
    ],
)  # fmt: skip
def test_a_bad_frames_section_is_refused_in_one_line(tmp_path, frames, says):
    path = _file(tmp_path, "frames:\n" + frames)
    with pytest.raises(DescriptionError, match=r"arm\.yaml: frames") as refused:
        robots.get(path)
    assert says in str(refused.value) and "\n" not in str(refused.value)
