"""Descriptions whose data break the symmetries a mirrored limit or interval hides behind.

Every reversed joint of the shipped arms has symmetric limits and every
forked link pair is symmetric, so a limit or a narrowed interval mirrored
the wrong way passed. Here: a URDF whose reversed joints (KUKA's A1 and A6,
axes along -z and -x) have asymmetric limits, checked against yourdfpy;
couplings with factors other than 1 (hypothesis over the convention);
a mimic joint in the chain (refused) and beside it (a gripper's finger,
accepted); and a wrist fork whose two sides leave the flange different room.
"""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
import yourdfpy
from hypothesis import given, settings
from hypothesis import strategies as st
from robot_files_kit import KUKA
from scipy.spatial import cKDTree
from urdf_mesh_kit import arm_with_meshes, box, housings, posed_mm

from calibrator import robots
from calibrator.model import kinematics
from calibrator.robots import DescriptionError, JointConvention, urdf

SETTINGS = settings(max_examples=60, deadline=None, derandomize=True)
#: URDF limits (rad) of KUKA's reversed joints, made asymmetric.
A1 = (-2.0, 2.9)
A6 = (-5.0, 6.0)
#: ... and of A4, whose URDF axis is -x too but which the model turns about as written.
A4 = (-1.5, 3.0)


def _asymmetric(text=KUKA):
    out = text
    for name, (lo, hi), old in (
        ("a1", A1, 'lower="-2.9670597283903604" upper="2.9670597283903604"'),
        ("a4", A4, 'lower="-3.2288591161895095" upper="3.2288591161895095"'),
        ("a6", A6, 'lower="-6.1086523819801535" upper="6.1086523819801535"'),
    ):
        assert out.count(old) == 1, name
        out = out.replace(old, f'lower="{lo}" upper="{hi}"')
    return out


@pytest.fixture
def kuka(tmp_path):
    path = tmp_path / "arm.urdf"
    path.write_text(_asymmetric())
    return path


def test_a_reversed_joints_asymmetric_limits_are_mirrored_into_the_model(kuka):
    arm = robots.get(str(kuka))
    assert arm.convention.sign == (-1.0, 1.0, 1.0, 1.0, 1.0, -1.0)
    lim = arm.joint_limits_rad
    np.testing.assert_allclose(lim[0], (-A1[1], -A1[0]))  # model = -URDF: [-2.9, 2.0]
    np.testing.assert_allclose(lim[5], (-A6[1], -A6[0]))
    np.testing.assert_allclose(lim[3], A4)  # not reversed in the model: as written
    # The controller's (the URDF's) angles are the URDF's limits again.
    box_ = arm.controller_box()
    np.testing.assert_allclose(box_[[0, 3, 5]], [A1, A4, A6])


def test_the_model_at_its_limits_is_the_urdf_at_its_limits(kuka):
    """yourdfpy, another URDF reader, poses the tip where the model does at each limit's end."""
    arm = robots.get(str(kuka))
    model = yourdfpy.URDF.load(str(kuka), load_meshes=False, build_collision_scene_graph=False)
    names = [f"joint_a{i}" for i in range(1, 7)]
    rng = np.random.default_rng(3)
    for joint in (0, 3, 5):
        for end in (0, 1):
            q = rng.uniform(-0.5, 0.5, 6)
            q[joint] = arm.joint_limits_rad[joint, end]
            q_urdf = arm.convention.to_controller(q)
            lo = np.array([model.joint_map[n].limit.lower for n in names])
            hi = np.array([model.joint_map[n].limit.upper for n in names])
            assert np.all(q_urdf >= lo - 1e-12) and np.all(q_urdf <= hi + 1e-12), (joint, end)
            # A reversed joint's model lower limit is its URDF upper limit.
            urdf_end = (lo, hi)[end if joint == 3 else 1 - end]
            assert np.isclose(q_urdf[joint], urdf_end[joint]), (joint, end)
            model.update_cfg(dict(zip(names, q_urdf, strict=True)))
            want = np.array(model.get_transform("tool0", "base_link"))  # the tip
            want[:3, 3] *= 1000.0
            got = arm.base_offset @ kinematics.chain(arm.mdh, q[None])[0] @ arm.flange_offset
            np.testing.assert_allclose(got, want, atol=1e-6)


def test_a_breach_of_a_reversed_joint_is_named_in_the_controllers_angles(kuka):
    arm = robots.get(str(kuka))
    q = np.zeros((3, 6))
    q[0, 0] = -2.85  # model: URDF/controller A1 = 2.85, inside [-2.0, 2.9]
    q[1, 0] = 2.05  # model: A1 = -2.05, beyond -2.0
    q[2, 5] = 5.5  # model: A6 = -5.5, beyond -5.0
    out = arm.outside_limits(q)
    assert out.tolist() == [[False] * 6, [True] + [False] * 5, [False] * 5 + [True]]
    assert arm.limit_breach(q[1:2]) == (0, "joint 1: -2.05 rad outside [-2, 2.9]")
    assert arm.limit_breach(q[2:3]) == (0, "joint 6: -5.5 rad outside [-5, 6]")
    assert arm.limit_breach(q[:1]) is None


# -- couplings ---------------------------------------------------------------------------------

_factor = st.sampled_from([1.0, -1.0, 0.5, -0.75, 2.0])
_angle = st.floats(-3.0, 3.0, allow_nan=False)


@SETTINGS
@given(
    sign=st.lists(st.sampled_from([1.0, -1.0]), min_size=6, max_size=6),
    offset=st.lists(st.floats(-1.0, 1.0, allow_nan=False), min_size=6, max_size=6),
    f32=_factor,
    f41=_factor,
    q=st.lists(_angle, min_size=6, max_size=6),
)
def test_a_convention_with_couplings_inverts_and_its_model_box_holds_every_controller_pose(
    sign, offset, f32, f41, q
):
    conv = JointConvention(tuple(sign), tuple(offset), ((2, 1, f32), (3, 0, f41)))
    q_ctrl = np.array([q])
    q_model = conv.to_model(q_ctrl)
    # The definition, written out: model = sign * ctrl + offset + f * earlier ctrl.
    want = np.array(sign) * q_ctrl[0] + np.array(offset)
    want[2] += f32 * q_ctrl[0, 1]
    want[3] += f41 * q_ctrl[0, 0]
    np.testing.assert_allclose(q_model[0], want, atol=1e-12)
    np.testing.assert_allclose(conv.to_controller(q_model), q_ctrl, atol=1e-9)
    # An asymmetric controller box: every pose in it is in the model box, and each
    # model box end is reached at a corner of the controller box.
    box_ = np.array([[-2.5, 1.0], [-0.5, 2.5], [-1.2, 0.3], [-3.0, 2.0], [-1.0, 1.5], [-0.2, 3.0]])
    inside = np.clip(q_ctrl, box_[:, 0], box_[:, 1])
    m_box = conv.model_box(box_)
    m = conv.to_model(inside)[0]
    assert np.all(m >= m_box[:, 0] - 1e-9) and np.all(m <= m_box[:, 1] + 1e-9)
    corners = np.array(np.meshgrid(*box_[[0, 1]], indexing="ij")).reshape(2, -1).T
    full = np.tile(box_.mean(axis=1), (len(corners) * 4, 1))
    for k, (a, b) in enumerate(corners):
        for m_, (c, d) in enumerate([(0, 0), (0, 1), (1, 0), (1, 1)]):
            full[4 * k + m_, [0, 1, 2, 3]] = a, b, box_[2, c], box_[3, d]
    reached = conv.to_model(full)
    np.testing.assert_allclose(reached[:, [2, 3]].min(axis=0), m_box[[2, 3], 0], atol=1e-9)
    np.testing.assert_allclose(reached[:, [2, 3]].max(axis=0), m_box[[2, 3], 1], atol=1e-9)


COUPLED = """\
format: calibrator-robot/1
name: coupled-arm
source: the shipped M-20iA URDF, a coupling of factor {factor} and the controller's limits
kinematics:
  urdf: arm.urdf
  tip_link: flange
limits:
  lower_deg: [-170, -100, -70, -200, -140, -270]
  upper_deg: [170, 160, 60, 200, 140, 270]
convention:
  sign: [1, 1, 1, 1, 1, 1]
  couplings: [{{joint: 3, from: 2, factor: {factor}}}]
  source: a test's coupling
body:
  margin_mm: 10
  base_radius_mm: 260
  base_top_mm: 300
  link_radius_mm: [200, 150, 140, 110, 90, 60]
"""


@pytest.mark.parametrize("factor", [1.0, -0.5])
def test_a_coupled_joints_model_range_and_breaches_follow_its_factor(tmp_path, factor):
    """The model's J3 = J3 + f J2 spans the sum of both boxes, the lower ends paired by f's sign."""
    import shutil

    shutil.copy(
        robots.__file__.replace("__init__.py", "data/fanuc-m20ia.urdf"), tmp_path / "arm.urdf"
    )
    (tmp_path / "arm.yaml").write_text(COUPLED.format(factor=factor))
    arm = robots.get(str(tmp_path / "arm.yaml"))
    j2, j3 = np.radians([-100.0, 160.0]), np.radians([-70.0, 60.0])
    ends = np.sort(factor * j2)
    np.testing.assert_allclose(arm.joint_limits_rad[2], j3 + ends)
    # J2 at its upper end and J3 just beyond its lower: the model's J3 may be anywhere in
    # its box, the controller's J3 is out, and the breach says so in the controller's angles.
    q_ctrl = np.radians([[0.0, 150.0, -75.0, 0.0, 10.0, 0.0], [0.0, 150.0, -65.0, 0.0, 10.0, 0.0]])
    q_model = arm.convention.to_model(q_ctrl)
    np.testing.assert_allclose(q_model[:, 2], q_ctrl[:, 2] + factor * q_ctrl[:, 1])
    assert arm.outside_limits(q_model).tolist() == [
        [False, False, True, False, False, False],
        [False] * 6,
    ]
    row, what = arm.limit_breach(q_model)
    assert (
        row == 0
        and what == f"joint 3: {np.radians(-75.0):.6g} rad outside [{j3[0]:.6g}, {j3[1]:.6g}]"
    )


# -- mimic joints --------------------------------------------------------------------------


def test_a_mimic_joint_in_the_chain_is_refused_naming_it(tmp_path):
    text = KUKA.replace(
        '<joint name="joint_a3" type="revolute">',
        '<joint name="joint_a3" type="revolute">\n    <mimic joint="joint_a2" multiplier="-1"/>',
    )
    path = tmp_path / "arm.urdf"
    path.write_text(text)
    with pytest.raises(DescriptionError, match=r"joint_a3.* mimics another joint"):
        robots.get(str(path))


def test_a_mimic_joint_beside_the_chain_is_no_concern_of_the_arm(tmp_path):
    """A gripper's second finger mimics its first: not between the base and the flange."""
    fingers = """<link name="finger_1"/><link name="finger_2"/>
  <joint name="finger_joint_1" type="prismatic">
    <parent link="flange"/><child link="finger_1"/><axis xyz="0 1 0"/>
    <limit lower="0" upper="0.04" effort="10" velocity="0.1"/>
  </joint>
  <joint name="finger_joint_2" type="prismatic">
    <parent link="flange"/><child link="finger_2"/><axis xyz="0 -1 0"/>
    <limit lower="0" upper="0.04" effort="10" velocity="0.1"/>
    <mimic joint="finger_joint_1" multiplier="1"/>
  </joint>
</robot>"""
    path = tmp_path / "arm.urdf"
    path.write_text(KUKA.replace("</robot>", fingers))
    arm = robots.get(str(path))
    bare = tmp_path / "bare.urdf"
    bare.write_text(KUKA)
    alone = robots.get(str(bare))
    np.testing.assert_allclose(arm.mdh, alone.mdh)
    np.testing.assert_allclose(arm.joint_limits_rad, alone.joint_limits_rad)
    assert arm.convention == alone.convention


# -- an asymmetric wrist fork --------------------------------------------------------------

#: Axis 5 of the KUKA URDF in link_4's frame (m).
AXIS_5_X = 0.42


def _lopsided():
    """A forearm whose end leaves the flange 70 mm on one side of axis 5 and 90 on the other."""
    meshes = housings()
    top, bottom = AXIS_5_X - 0.07, AXIS_5_X - 0.09
    meshes["link_4"] = trimesh.util.concatenate(
        [
            box((-0.05, -0.05, 0.0), (top, 0.05, 0.05)),
            box((-0.05, -0.05, -0.05), (bottom, 0.05, 0.0)),
            box((bottom, 0.07, -0.05), (AXIS_5_X + 0.05, 0.09, 0.05)),
            box((bottom, -0.09, -0.05), (AXIS_5_X + 0.05, -0.07, 0.05)),
        ]
    )
    return meshes


def _gap(path, meshes, q5):
    """Least distance of link_4's and link_6's surface points, joint 6 all round (mm)."""
    model = yourdfpy.URDF.load(str(path), load_meshes=False, build_collision_scene_graph=False)
    points = {k: trimesh.sample.sample_surface(meshes[k], 4000, seed=1)[0] for k in meshes}
    least = np.inf
    for q6 in np.radians(np.arange(0.0, 360.0, 5.0)):
        model.update_cfg({"joint_a5": q5, "joint_a6": q6})
        placed = posed_mm(model, {name: points[name] for name in ("link_4", "link_6")})
        least = min(least, cKDTree(placed["link_4"]).query(placed["link_6"])[0].min())
    return least


def test_a_lopsided_fork_narrows_joint_5_on_each_side_to_its_own_room(tmp_path):
    meshes = _lopsided()
    path = arm_with_meshes(tmp_path, meshes)
    arm = urdf.describe(path)
    lo, hi = arm.joint_limits_rad[4]
    # The sides differ by far more than the sweep's step: a mirrored interval is wrong.
    assert abs(abs(lo) - abs(hi)) > np.radians(8.0), np.degrees([lo, hi])
    assert lo > np.radians(-120.0) and hi < np.radians(120.0)  # both sides narrowed
    for end in (lo, hi):
        gap = _gap(path, meshes, end)
        assert urdf.FIT_MARGIN_MM - 3.0 < gap < urdf.FIT_MARGIN_MM + 6.0, (np.degrees(end), gap)
    # Past each end by a few degrees the surfaces come closer than the margin.
    assert _gap(path, meshes, lo - np.radians(4.0)) < urdf.FIT_MARGIN_MM
    assert _gap(path, meshes, hi + np.radians(4.0)) < urdf.FIT_MARGIN_MM
