"""A description file's convention over a URDF whose joints 1 and 6 are reversed.

The file's ``convention`` takes the controller's angles to the URDF's
(``urdf = sign * ctrl + offset + factor * earlier ctrl``); the model angle of
KUKA's A1 and A6 is minus the URDF's. So an offset or a coupling on those
joints must reach the model negated. Checked against yourdfpy (another URDF
reader) at the URDF angles the file's definition gives, and the file's
limits (controller angles) against the model's box.
"""

from __future__ import annotations

import shutil

import numpy as np
import pytest
import yourdfpy
from robot_files_kit import DATA

from calibrator import robots
from calibrator.model import kinematics

FILE = """\
format: calibrator-robot/1
name: offset-arm
source: the shipped KR 6 URDF with a controller that counts A1 and A6 from elsewhere
kinematics:
  urdf: arm.urdf
limits:
  lower_deg: [-150, -190, -120, -185, -120, -300]
  upper_deg: [100, 45, 156, 185, 120, 200]
convention:
  sign: [1, 1, 1, 1, 1, -1]
  offset_deg: [20, 0, 0, 0, 0, 30]
  couplings: [{joint: 6, from: 5, factor: 0.5}]
  source: a test's convention
body:
  link_radius_mm: [100, 80, 70, 60, 50, 40]
"""
NAMES = [f"joint_a{i}" for i in range(1, 7)]
SIGN = np.array([1.0, 1, 1, 1, 1, -1])
OFFSET = np.radians([20.0, 0, 0, 0, 0, 30])


def _urdf_angles(q_ctrl):
    """The file's definition written out: URDF = sign * ctrl + offset + 0.5 * ctrl 5 on A6."""
    out = SIGN * q_ctrl + OFFSET
    out[..., 5] += 0.5 * q_ctrl[..., 4]
    return out


@pytest.fixture(scope="module")
def arm(tmp_path_factory):
    folder = tmp_path_factory.mktemp("convention")
    shutil.copy(DATA / "kuka-kr6-r900.urdf", folder / "arm.urdf")
    (folder / "arm.yaml").write_text(FILE)
    return folder, robots.get(str(folder / "arm.yaml"))


def test_the_model_at_the_controllers_angles_is_the_urdf_at_the_files_angles(arm):
    folder, described = arm
    conv = described.convention
    assert conv.sign == (
        -1.0,
        1.0,
        1.0,
        1.0,
        1.0,
        1.0,
    )  # the URDF's A1, A6 reversal times the file's
    np.testing.assert_allclose(conv.offset_rad, [-OFFSET[0], 0, 0, 0, 0, -OFFSET[5]])
    assert conv.couplings == ((5, 4, -0.5),)
    model = yourdfpy.URDF.load(
        str(folder / "arm.urdf"), load_meshes=False, build_collision_scene_graph=False
    )
    rng = np.random.default_rng(11)
    q_ctrl = rng.uniform(-1.5, 1.5, (5, 6))
    q_model = conv.to_model(q_ctrl)
    np.testing.assert_allclose(conv.to_controller(q_model), q_ctrl, atol=1e-12)
    tips = (
        described.base_offset @ kinematics.chain(described.mdh, q_model) @ described.flange_offset
    )
    for q, tip in zip(_urdf_angles(q_ctrl), tips, strict=True):
        model.update_cfg(dict(zip(NAMES, q, strict=True)))
        want = np.array(model.get_transform("tool0", "base_link"))
        want[:3, 3] *= 1000.0
        np.testing.assert_allclose(tip, want, atol=1e-6)


def test_the_files_limits_are_the_controllers_and_the_model_box_holds_them(arm):
    _, described = arm
    lower = np.radians([-150.0, -190, -120, -185, -120, -300])
    upper = np.radians([100.0, 45, 156, 185, 120, 200])
    # Coupled: the stated limits are kept as the controller's.
    np.testing.assert_allclose(described.controller_limits_rad, np.column_stack([lower, upper]))
    lim = described.joint_limits_rad
    # A1: model = -(ctrl + 20 deg), an asymmetric range mirrored.
    np.testing.assert_allclose(lim[0], np.radians([-120.0, 130.0]))
    # A6: model = -(-ctrl + 30 deg + 0.5 ctrl5) = ctrl - 30 deg - 0.5 ctrl5.
    np.testing.assert_allclose(lim[5], np.radians([-300.0 - 30 - 60, 200.0 - 30 + 60]))
    # Every corner of the controller's box is inside the model's, and named so.
    corners = np.array(np.meshgrid(*np.column_stack([lower, upper]), indexing="ij"))
    corners = corners.reshape(6, -1).T
    q_model = described.convention.to_model(corners)
    assert not described.outside_limits(q_model, tolerance_rad=1e-12).any()
    inside = described.convention.to_model(0.999 * corners)  # off the ends' rounding
    assert described.limit_breach(inside) is None
    # Just past the controller's A1 upper limit (the model's lower end side).
    past = np.zeros((1, 6))
    past[0, 0] = np.radians(101.0)
    q = described.convention.to_model(past)
    assert described.outside_limits(q).tolist() == [[True] + [False] * 5]
    assert described.limit_breach(q) == (
        0,
        f"joint 1: {np.radians(101.0):.6g} rad outside [{lower[0]:.6g}, {upper[0]:.6g}]",
    )
