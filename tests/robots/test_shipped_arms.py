"""Shipped descriptions of five brands' arms, each against an independent reading of its URDF."""

from pathlib import Path

import numpy as np
import pytest
import yourdfpy

from calibrator import cell, planning, robots
from calibrator.model import kinematics

DATA = Path(robots.__file__).with_name("data")
# The tip link each shipped description names, and its controller's own joint
# convention typed from the ROS-Industrial drivers (not from the descriptions):
# every driver relays the controller's angles unchanged but FANUC's, whose
# fanuc_driver gives ROS J3 = J3 + J2 (J23_factor 1, fanuc_utils.h).
ARMS = {
    "kuka-kr6-r900": "flange",
    "abb-irb4600-60-205": "flange",
    "fanuc-m20ia": "flange",
    "yaskawa-gp8": "tool0",
    "staubli-tx2-60": "flange",
}


def ros_angles(name, q_ctrl):
    q = np.array(q_ctrl, dtype=float)
    if name == "fanuc-m20ia":
        q[:, 2] = q_ctrl[:, 2] + q_ctrl[:, 1]
    return q


def urdf_poses(name, q_ros):
    """Base link to tip link by yourdfpy (m -> mm), one per row of ``q_ros``."""
    model = yourdfpy.URDF.load(
        str(DATA / f"{name}.urdf"), load_meshes=False, build_collision_scene_graph=False
    )
    joints = model.actuated_joint_names
    assert len(joints) == 6
    out = []
    for q in q_ros:
        model.update_cfg(dict(zip(joints, q, strict=True)))
        t = np.array(model.get_transform(ARMS[name], "base_link"))
        t[:3, 3] *= 1000.0
        out.append(t)
    return np.array(out)


def controller_poses(arm, n, seed):
    """Controller angles spread over the joint ranges (rad), (n, 6)."""
    rng = np.random.default_rng(seed)
    lo, hi = arm.joint_limits_rad[:, 0], arm.joint_limits_rad[:, 1]
    return arm.convention.to_controller(rng.uniform(lo, hi, (n, 6)))


def test_every_brand_is_shipped():
    assert set(ARMS) <= set(robots.names())


@pytest.mark.parametrize("name", sorted(ARMS))
def test_forward_kinematics_equal_an_independent_urdf_reading(name):
    arm = robots.get(name)
    q_ctrl = controller_poses(arm, 200, seed=1)
    expected = urdf_poses(name, ros_angles(name, q_ctrl))
    got = arm.base_offset @ kinematics.chain(arm.mdh, arm.convention.to_model(q_ctrl))
    got = got @ arm.flange_offset
    assert np.abs(got[:, :3, 3] - expected[:, :3, 3]).max() < 1e-9  # mm
    assert np.abs(got[:, :3, :3] - expected[:, :3, :3]).max() < 1e-12


@pytest.mark.parametrize("name", sorted(ARMS))
def test_joint_convention_round_trips(name):
    arm = robots.get(name)
    q_ctrl = controller_poses(arm, 1000, seed=2)
    back = arm.convention.to_controller(arm.convention.to_model(q_ctrl))
    if arm.convention.couplings:
        # fl(fl(a + b) - b) is a to within one rounding of a + b.
        bound = np.spacing(np.abs(q_ctrl).sum(axis=1, keepdims=True))
        assert np.all(np.abs(back - q_ctrl) <= bound)
    else:
        np.testing.assert_array_equal(back, q_ctrl)  # signs and zero offsets: bit for bit


def test_fanuc_j3_is_coupled_to_j2_and_kuka_a1_and_a6_turn_the_other_way():
    fanuc, kuka = robots.get("fanuc-m20ia"), robots.get("kuka-kr6-r900")
    q = np.radians([[10.0, 20.0, 30.0, 40.0, 50.0, 60.0]])
    np.testing.assert_allclose(fanuc.convention.to_model(q)[0, 2], np.radians(50.0))
    np.testing.assert_allclose(
        kuka.convention.to_model(q)[0], np.radians([-10, 20, 30, 40, 50, -60])
    )


@pytest.mark.parametrize("name", sorted(ARMS))
def test_a_plan_for_the_arm_passes_its_own_capsule_checks(name):
    arm = robots.get(name)
    tool = (0.0, 0.0, 80.0)
    reach = cell.arm_geometry(arm, arm.mdh, tool).reach_mm
    where = cell.Cell(tracker_at_mm=(reach + 1500.0, 300.0, 300.0))
    made = planning.make_checked(arm, 24, where, tool, seed=3)
    planning.check_plan(made.plan, arm, where, tool)
    assert made.plan.q_rad.shape == (24, 6)
    inside = (made.plan.q_rad >= arm.joint_limits_rad[:, 0]) & (
        made.plan.q_rad <= arm.joint_limits_rad[:, 1]
    )
    assert inside.all()
