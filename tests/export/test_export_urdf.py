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

REVOLUTE = ("shoulder_pan", "shoulder_lift", "elbow", "wrist_1", "wrist_2", "wrist_3")


def numbers(text):
    return [float(v) for v in text.split()]


def parsed(cal):
    return ET.fromstring(export.export(cal, "urdf").text)


def joint_map(root):
    return {j.get("name"): j for j in root.findall("joint")}


def chain_from_xml(root, q):
    """base_link -> flange and -> tool at each row of q (mm), joint by joint."""
    joints = joint_map(root)
    out_flange, out_tool = [], []
    for row in q:
        t = np.eye(4)
        for i, name in enumerate(REVOLUTE):
            j = joints[f"{name}_joint"]
            o = j.find("origin")
            xyz, rpy = numbers(o.get("xyz")), numbers(o.get("rpy"))
            assert len(xyz) == 3 and len(rpy) == 3, (xyz, rpy)
            assert numbers(j.find("axis").get("xyz")) == [0.0, 0.0, 1.0]
            spin = np.eye(4)
            spin[:3, :3] = rot("z", row[i])
            t = t @ urdf_origin(np.array(xyz) * 1000.0, rpy) @ spin
        for fixed in ("wrist_3_link-flange", "flange-tool"):
            o = joints[fixed].find("origin")
            xyz, rpy = numbers(o.get("xyz")), numbers(o.get("rpy"))
            assert len(xyz) == 3 and len(rpy) == 3, (xyz, rpy)
            t = t @ urdf_origin(np.array(xyz) * 1000.0, rpy)
            (out_flange if fixed.endswith("flange") else out_tool).append(t)
    return np.array(out_flange), np.array(out_tool)


@pytest.mark.parametrize("model", ["ur10e", "er10l-c10"])
def test_urdf_chain_written_out_is_the_calibrated_flange_and_tool(model):
    cal = calibrated(model, seed=11)
    root = parsed(cal)
    q = poses(60, seed=3)
    flange, tool = chain_from_xml(root, q)
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
    joints = joint_map(root)
    lim = [joints[f"{n}_joint"].find("limit") for n in REVOLUTE]
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
