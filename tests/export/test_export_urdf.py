"""The URDF export read back by independent readers (ElementTree, yourdfpy).

What the file must hold, whatever the exporter's code: six revolute joints
and two fixed ones whose origins, chained with ``Rz(q)`` per joint, are the
calibrated chain and tool to 1e-6 mm; the joint limits and speeds of the
named model (UR: +-2 pi, elbow +-pi; a safe +-2 pi and pi rad/s when the
model is unknown or unnamed); an XML-safe robot name.
"""

import xml.etree.ElementTree as ET
from dataclasses import replace

import numpy as np
import pytest
import yourdfpy
from export_kit import calibrated, poses, rot, urdf_origin

from calibrator import export, robots
from calibrator.model import kinematics
from calibrator.robots import shipped

REVOLUTE = ("shoulder_pan", "shoulder_lift", "elbow", "wrist_1", "wrist_2", "wrist_3")


def numbers(text):
    return [float(v) for v in text.split()]


def parsed(cal):
    return ET.fromstring(export.export(cal, "urdf").text)


def joint_map(root):
    return {j.get("name"): j for j in root.findall("joint")}


def chain_from_xml(root, q, last="wrist_3_link"):
    """base_link -> flange and -> tool at each row of q (mm), joint by joint.

    ``q`` are the joint values the file's joints take (the controller's):
    each revolute joint, in file order, turns about its axis, +z or -z.
    """
    joints = joint_map(root)
    revolute = [j for j in root.findall("joint") if j.get("type") == "revolute"]
    assert len(revolute) == 6
    out_flange, out_tool = [], []
    for row in q:
        t = np.eye(4)
        for i, j in enumerate(revolute):
            o = j.find("origin")
            xyz, rpy = numbers(o.get("xyz")), numbers(o.get("rpy"))
            assert len(xyz) == 3 and len(rpy) == 3, (xyz, rpy)
            axis = numbers(j.find("axis").get("xyz"))
            assert axis in ([0.0, 0.0, 1.0], [0.0, 0.0, -1.0]), axis
            spin = np.eye(4)
            spin[:3, :3] = rot("z", axis[2] * row[i])
            t = t @ urdf_origin(np.array(xyz) * 1000.0, rpy) @ spin
        for fixed in (f"{last}-flange", "flange-tool"):
            o = joints[fixed].find("origin")
            xyz, rpy = numbers(o.get("xyz")), numbers(o.get("rpy"))
            assert len(xyz) == 3 and len(rpy) == 3, (xyz, rpy)
            t = t @ urdf_origin(np.array(xyz) * 1000.0, rpy)
            (out_flange if fixed.endswith("flange") else out_tool).append(t)
    return np.array(out_flange), np.array(out_tool)


@pytest.mark.parametrize(
    "model, last", [("ur10e", "wrist_3_link"), ("er10l-c10", "link_6"), ("kuka-kr6-r900", "link_6")]
)
def test_urdf_chain_written_out_is_the_calibrated_flange_and_tool(model, last):
    cal = calibrated(model, seed=11)
    root = parsed(cal)
    q = poses(60, seed=3)
    # The file's joints take the controller's angles (a KUKA's A1 and A6: the model's negative).
    flange, tool = chain_from_xml(root, robots.get(model).convention.to_controller(q), last)
    want = kinematics.chain(cal.mdh, q)
    np.testing.assert_allclose(flange[:, :3, 3], want[:, :3, 3], rtol=0, atol=1e-6)
    np.testing.assert_allclose(flange[:, :3, :3], want[:, :3, :3], rtol=0, atol=1e-9)
    want_tool = want @ cal.flange2tool
    np.testing.assert_allclose(tool[:, :3, 3], want_tool[:, :3, 3], rtol=0, atol=1e-6)
    np.testing.assert_allclose(tool[:, :3, :3], want_tool[:, :3, :3], rtol=0, atol=1e-9)


def test_urdf_tree_is_base_link_to_tool_in_order():
    root = parsed(calibrated())
    links = [link.get("name") for link in root.findall("link")]
    expected_links = ["base_link"] + [
        f"{n}_link" for n in ("shoulder", "upper_arm", "forearm", "wrist_1", "wrist_2", "wrist_3")
    ]
    assert links == expected_links + ["flange", "tool"]
    joints = root.findall("joint")
    assert [j.get("type") for j in joints] == ["revolute"] * 6 + ["fixed"] * 2
    # Each joint hangs off the previous child: one unbroken chain.
    chain = [(j.find("parent").get("link"), j.find("child").get("link")) for j in joints]
    assert chain == list(zip(links[:-1], links[1:], strict=True))


def test_yourdfpy_flange_link_is_the_mdh_flange(tmp_path):
    cal = calibrated("ur10e", seed=12)
    path = tmp_path / "arm.urdf"
    path.write_text(export.export(cal, "urdf").text)
    robot = yourdfpy.URDF.load(str(path), load_meshes=False, build_collision_scene_graph=False)
    names = [f"{n}_joint" for n in REVOLUTE]
    assert list(robot.actuated_joint_names) == names
    q = poses(30, seed=5)
    want = kinematics.chain(cal.mdh, q)
    for row, pose in zip(q, want, strict=True):
        robot.update_cfg(dict(zip(names, row, strict=True)))
        got = robot.get_transform("flange", "base_link")
        np.testing.assert_allclose(got[:3, 3] * 1000.0, pose[:3, 3], rtol=0, atol=1e-6)
        np.testing.assert_allclose(got[:3, :3], pose[:3, :3], rtol=0, atol=1e-9)


def limits_of(root):
    lim = [j.find("limit") for j in root.findall("joint") if j.get("type") == "revolute"]
    lower = np.array([float(x.get("lower")) for x in lim])
    upper = np.array([float(x.get("upper")) for x in lim])
    speed = np.array([float(x.get("velocity")) for x in lim])
    effort = np.array([float(x.get("effort")) for x in lim])
    return lower, upper, speed, effort


def test_urdf_limits_are_the_named_models():
    lower, upper, speed, effort = limits_of(parsed(calibrated("ur10e")))
    # UR10e: every joint +-360 deg except the elbow's +-180 deg; 120 deg/s
    # for the two big joints, 180 deg/s for the others.
    np.testing.assert_allclose(upper, np.radians([360, 360, 180, 360, 360, 360]), rtol=1e-15)
    np.testing.assert_allclose(lower, -upper, rtol=0)
    np.testing.assert_allclose(speed, np.radians([120, 120, 180, 180, 180, 180]), rtol=1e-15)
    assert np.all(effort > 0)
    lower, upper, speed, _ = limits_of(parsed(calibrated("er10l-c10")))
    np.testing.assert_allclose(upper, np.full(6, np.pi), rtol=1e-15)
    np.testing.assert_allclose(lower, -upper, rtol=0)
    np.testing.assert_allclose(speed, robots.get("er10l-c10").max_joint_speed_rad_s)


def shipped_urdf_joints(name):
    """The revolute joints of a shipped arm's own URDF, read with ElementTree."""
    root = ET.parse(shipped.DATA / f"{name}.urdf").getroot()
    return [j for j in root.findall("joint") if j.get("type") == "revolute"]


def test_a_kuka_urdf_names_its_joints_and_limits_as_kukas_own_urdf():
    root = parsed(calibrated("kuka-kr6-r900", seed=2))
    own = shipped_urdf_joints("kuka-kr6-r900")
    written = [j for j in root.findall("joint") if j.get("type") == "revolute"]
    assert [j.get("name") for j in written] == [j.get("name") for j in own]
    assert [j.get("name") for j in own] == [f"joint_a{i}" for i in range(1, 7)]
    # A1 and A6 turn about -z: the controller's angles are the model's negative there.
    assert [numbers(j.find("axis").get("xyz"))[2] for j in written] == [-1, 1, 1, 1, 1, -1]
    # Limits in A1..A6 as KUKA's own URDF gives them (A2: -190..45 deg), not in model signs.
    lower, upper, _, _ = limits_of(root)
    own_lower = [float(j.find("limit").get("lower")) for j in own]
    own_upper = [float(j.find("limit").get("upper")) for j in own]
    np.testing.assert_allclose(lower, own_lower, rtol=0, atol=1e-12)
    np.testing.assert_allclose(upper, own_upper, rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.degrees([lower[1], upper[1]]), [-190, 45], atol=1e-9)


@pytest.mark.parametrize("model", [None, "my-own-arm"])
def test_urdf_of_an_unnamed_or_unknown_model_has_full_turn_limits(model):
    cal = replace(calibrated("ur10e"), model=model)
    root = parsed(cal)
    lower, upper, speed, _ = limits_of(root)
    np.testing.assert_array_equal(lower, np.full(6, -2 * np.pi))
    np.testing.assert_array_equal(upper, np.full(6, 2 * np.pi))
    np.testing.assert_array_equal(speed, np.full(6, np.pi))
    assert root.get("name") == f"{model or 'arm'}_calibrated"


def test_urdf_robot_name_is_escaped():
    cal = replace(calibrated("ur10e"), model='cell "A" & <B>')
    root = parsed(cal)
    assert root.get("name") == 'cell "A" & <B>_calibrated'
    assert root.get("name") and parsed(calibrated("ur10e")).get("name") == "ur10e_calibrated"
