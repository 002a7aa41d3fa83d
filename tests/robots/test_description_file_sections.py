"""What a description file or URDF leaves out keeps what the arm's source gives.

A missing file is refused naming it; a continuous joint without limits
turns two turns each way; a ``limits:`` section of speeds only keeps the
URDF's limits (a reversed joint's asymmetric range mirrored once, not
twice); the shoulder is on the base's axis; a coupling to a 7th joint is
refused as such; a link drawn along its joints stops its radius short of
the flange, where the tool is.
"""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from robot_files_kit import DATA, DESCRIPTION, KUKA

from calibrator import robots
from calibrator.model import kinematics
from calibrator.robots import DescriptionError


@pytest.mark.parametrize("name", ["arm.urdf", "arm.yaml", "arm.urdf#base_link:flange"])
def test_a_missing_file_is_refused_naming_it(tmp_path, name):
    with pytest.raises(DescriptionError) as refused:
        robots.get(str(tmp_path / name))
    assert str(refused.value) == f"{tmp_path / name.split('#')[0]}: no such file"


def test_a_continuous_joint_without_limits_turns_two_turns_each_way(tmp_path):
    a4 = '<joint name="joint_a4" type="revolute">'
    limit = 'lower="-3.2288591161895095" upper="3.2288591161895095" '
    text = KUKA.replace(a4, '<joint name="joint_a4" type="continuous">').replace(limit, "")
    (tmp_path / "arm.urdf").write_text(text)
    arm = robots.get(str(tmp_path / "arm.urdf"))
    np.testing.assert_allclose(arm.joint_limits_rad[3], [-2 * np.pi, 2 * np.pi])
    np.testing.assert_allclose(arm.max_joint_speed_rad_s[3], 6.649704450098396)


SPEEDS_ONLY = """\
format: calibrator-robot/1
name: speeds-only
source: the KR 6 URDF with asymmetric A1 limits, slower
kinematics:
  urdf: arm.urdf
limits:
  speed_deg_s: [100, 100, 100, 200, 200, 300]
body:
  margin_mm: 10
  link_radius_mm: [100, 80, 70, 60, 50, 40]
"""


def test_a_limits_section_of_speeds_only_keeps_the_urdfs_limits(tmp_path):
    old = 'lower="-2.9670597283903604" upper="2.9670597283903604"'
    (tmp_path / "arm.urdf").write_text(KUKA.replace(old, 'lower="-2.0" upper="2.9"'))
    (tmp_path / "arm.yaml").write_text(SPEEDS_ONLY)
    arm = robots.get(str(tmp_path / "arm.yaml"))
    alone = robots.get(str(tmp_path / "arm.urdf"))
    np.testing.assert_allclose(arm.joint_limits_rad[0], [-2.9, 2.0])  # model A1 = -URDF A1
    np.testing.assert_array_equal(arm.joint_limits_rad, alone.joint_limits_rad)
    np.testing.assert_allclose(
        arm.max_joint_speed_rad_s, np.radians([100, 100, 100, 200, 200, 300])
    )
    assert arm.controller_limits_rad is None


def test_a_description_files_shoulder_is_on_the_base_axis_at_joint_2s_height(tmp_path):
    (tmp_path / "arm.yaml").write_text(DESCRIPTION)
    arm = robots.get(str(tmp_path / "arm.yaml"))
    assert arm.body.shoulder_mm == (0.0, 0.0, 450.0)  # d1 of the table, the base at z = 0


def test_a_coupling_to_a_seventh_joint_is_refused_as_such(tmp_path):
    text = DESCRIPTION.replace(
        "  source: typed for a test\nbody:",
        "  couplings: [{joint: 7, from: 2, factor: 1}]\n  source: typed for a test\nbody:",
    )
    assert text != DESCRIPTION
    (tmp_path / "arm.yaml").write_text(text)
    with pytest.raises(
        DescriptionError, match=r"couplings\[0\]: joint: 7: joints are numbered 1 to 6"
    ):
        robots.get(str(tmp_path / "arm.yaml"))


def test_a_link_drawn_along_its_joints_stops_its_radius_short_of_the_flange(tmp_path):
    shutil.copy(DATA / "kuka-kr6-r900.urdf", tmp_path / "arm.urdf")
    arm = robots.get(str(tmp_path / "arm.urdf"))
    frames = arm.base_offset @ kinematics.chain(arm.mdh, np.zeros(6), all_frames=True)[1][0]
    flange = (frames[6] @ arm.flange_offset)[:3, 3]
    (link_6,) = (c for c in arm.body.capsules if c.link == 6)
    ends = [(frames[6] @ np.append(p, 1.0))[:3] for p in (link_6.p_mm, link_6.q_mm)]
    # The cap's far point is the flange itself: no further, so the tool is not swallowed.
    assert min(np.linalg.norm(e - flange) for e in ends) == pytest.approx(link_6.radius_mm)
    wrist = frames[5][:3, 3]
    out = (flange - wrist) / np.linalg.norm(flange - wrist)
    reach = max((e - wrist) @ out for e in ends) + link_6.radius_mm
    assert reach == pytest.approx(np.linalg.norm(flange - wrist))


def test_a_urdf_without_rep199_links_has_no_controller_frames_and_says_none(tmp_path):
    text = KUKA.replace('<link name="base"/>', "").replace('<link name="tool0"/>', "")
    for joint in ("flange-tool0", "base_link-base"):
        start = text.index(f'<joint name="{joint}"')
        text = text[:start] + text[text.index("</joint>", start) + len("</joint>") :]
    (tmp_path / "arm.urdf").write_text(text)
    arm = robots.get(str(tmp_path / "arm.urdf"))
    assert (arm.controller_base_source, arm.controller_flange_source) == ("", "")
    assert not arm.has_controller_frames
    with_links = robots.get(str(DATA / "kuka-kr6-r900.urdf"))
    assert (
        with_links.controller_base_source
        == "kuka-kr6-r900.urdf: link 'base' (REP-199's controller base frame)"
    )
    assert (
        with_links.controller_flange_source
        == "kuka-kr6-r900.urdf: link 'tool0' (REP-199's all-zero tool)"
    )


def test_a_massless_link_is_a_mass_of_zero_not_refused(tmp_path):
    text = KUKA.replace(
        '<link name="link_3"/>', '<link name="link_3"><inertial><mass value="0"/></inertial></link>'
    ).replace(
        '<link name="link_2"/>', '<link name="link_2"><inertial><mass value="2"/></inertial></link>'
    )
    (tmp_path / "arm.urdf").write_text(text)
    arm = robots.get(str(tmp_path / "arm.urdf"))
    np.testing.assert_array_equal(arm.mass_kg, [0.0, 2.0, 0.0, 0.0, 0.0, 0.0])


def test_a_urdf_without_a_known_tip_link_is_refused_naming_both_and_the_option(tmp_path):
    text = KUKA.replace('"tool0"', '"tcp"').replace('"flange"', '"plate"')
    (tmp_path / "arm.urdf").write_text(text)
    with pytest.raises(DescriptionError) as refused:
        robots.get(str(tmp_path / "arm.urdf"))
    assert str(refused.value) == (
        f"{tmp_path / 'arm.urdf'}: no tip link (tool0 or flange); name it with --tip-link"
    )
