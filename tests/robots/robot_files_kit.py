"""URDF texts for the robot-description tests (not a test module)."""

from pathlib import Path

from calibrator import robots

DATA = Path(robots.__file__).with_name("data")
#: The shipped KUKA KR 6 R900 URDF: joints only.
KUKA = (DATA / "kuka-kr6-r900.urdf").read_text()


def with_geometry(text):
    """The KUKA URDF with a box, a cylinder, a sphere and inertials on some links."""
    link_2 = """<link name="link_2">
    <inertial><origin xyz="0.2 0 0.01" rpy="0 0 0"/><mass value="8.0"/>
      <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>
    <visual><geometry><mesh filename="package://kuka_kr6_support/meshes/link_2.stl"/></geometry>
    </visual>
    <collision><origin xyz="0.2275 0 0" rpy="0.3 0 0"/>
      <geometry><box size="0.5 0.12 0.1"/></geometry></collision>
  </link>"""
    link_4 = """<link name="link_4">
    <inertial><origin xyz="0.15 0 0" rpy="0 0 0"/><mass value="3.0"/>
      <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>
    <collision><origin xyz="0.2 0 0" rpy="0 1.5707963267948966 0"/>
      <geometry><cylinder radius="0.05" length="0.3"/></geometry></collision>
  </link>"""
    link_6 = """<link name="link_6">
    <collision><origin xyz="-0.01 0 0" rpy="0 0 0"/>
      <geometry><sphere radius="0.04"/></geometry></collision>
  </link>"""
    return (
        text.replace('<link name="link_2"/>', link_2)
        .replace('<link name="link_4"/>', link_4)
        .replace('<link name="link_6"/>', link_6)
    )


def on_a_track(text):
    """The URDF ``text`` mounted on a linear track: a prismatic joint below ``base_link``."""
    track = """<link name="world"/>
  <link name="carriage"/>
  <joint name="track" type="prismatic">
    <parent link="world"/><child link="carriage"/><axis xyz="1 0 0"/>
    <limit lower="0" upper="3" effort="0" velocity="1"/>
  </joint>
  <joint name="carriage-base" type="fixed">
    <parent link="carriage"/><child link="base_link"/>
  </joint>
</robot>"""
    return text.replace("</robot>", track)


def seven_axes(text):
    """The URDF ``text`` with a 7th revolute joint between link_6 and tool0."""
    extra = """  <link name="link_7"/>
  <joint name="joint_a7" type="revolute">
    <origin xyz="0.05 0 0" rpy="0 0 0"/><parent link="link_6"/><child link="link_7"/>
    <axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="0" velocity="1"/>
  </joint>
  <joint name="link_7-tool0" type="fixed"><parent link="link_7"/><child link="tool0"/></joint>
</robot>"""
    start = text.index('<joint name="flange-tool0"')
    end = text.index("</joint>", start) + len("</joint>")
    return (text[:start] + text[end:]).replace("</robot>", extra)


def joint_1_on_the_plane(text):
    """The shipped ABB IRB 4600 URDF with joint 1's origin on the mounting plane.

    The same arm: the shoulder height moves to joint 2's origin, as ABB's
    IRB 2400 and Yaskawa's URDFs in ROS-Industrial write it.
    """
    return text.replace(
        '<origin xyz="0 0 0.495" rpy="0 0 0"/>\n    <parent link="base_link"/>',
        '<origin xyz="0 0 0" rpy="0 0 0"/>\n    <parent link="base_link"/>',
    ).replace('<origin xyz="0.175 0 0" rpy="0 0 0"/>', '<origin xyz="0.175 0 0.495" rpy="0 0 0"/>')


#: A description file with an MDH table, limits, a convention, a body and configurations.
DESCRIPTION = """format: calibrator-robot/1
name: test-arm
source: typed for a test
kinematics:
  mdh:
    - [150, -90, 0, 450, 0]
    - [600, 0, -90, 0, 0]
    - [120, -90, 0, 0, 0]
    - [0, 90, 0, 640, 0]
    - [0, -90, 0, 0, 0]
    - [0, 0, 0, 100, 0]
limits:
  lower_deg: [-170, -90, -170, -180, -120, -360]
  upper_deg: [170, 150, 80, 180, 120, 360]
  speed_deg_s: [150, 150, 150, 300, 300, 400]
  accel_deg_s2: [100, 100, 100, 200, 200, 200]
convention:
  sign: [-1, 1, 1, 1, 1, 1]
  offset_deg: [0, 90, 0, 0, 0, 0]
  source: typed for a test
body:
  base_radius_mm: 120
  base_top_mm: 320
  capsules:
    - {name: upper arm, link: 2, p_mm: [150, 0, 450], q_mm: [750, 0, 450], radius_mm: 90}
configurations:
  home: [0, 0, 0, 0, 0, 0]
  upright: [0, -90, 0, 0, 0, 0]
"""
