"""A coupled joint's limits are the controller's: stated, kept and checked as such.

FANUC limits J3 as its controller measures it, from the horizon; the model's
joint 3 is J3 + J2. A description file over a URDF declares the coupling and
the controller's limits; a pose whose model angles are fine but whose
controller J3 is beyond its limit is refused, by the plan check and by a
session, and named in the controller's angles.
"""

import json
import shutil
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

from calibrator import planning, robots, session
from calibrator.robots.description import DescriptionError

DATA = Path(robots.__file__).with_name("data")

DESCRIPTION = """\
format: calibrator-robot/1
name: coupled-arm
source: the shipped M-20iA URDF, its coupling and the controller's limits
kinematics:
  urdf: arm.urdf
  tip_link: flange
limits:
  lower_deg: [-170, -100, -70, -200, -140, -270]
  upper_deg: [170, 160, 60, 200, 140, 270]
convention:
  sign: [1, 1, 1, 1, 1, 1]
  couplings: [{joint: 3, from: 2, factor: 1}]
  source: fanuc_driver's J23 factor 1
body:
  margin_mm: 10
  base_radius_mm: 260
  base_top_mm: 300
  link_radius_mm: [200, 150, 140, 110, 90, 60]
"""


@pytest.fixture
def arm(tmp_path):
    shutil.copy(DATA / "fanuc-m20ia.urdf", tmp_path / "arm.urdf")
    (tmp_path / "arm.yaml").write_text(DESCRIPTION)
    return robots.get(str(tmp_path / "arm.yaml"))


def test_the_stated_limits_are_the_controllers_and_the_models_box_holds_them(arm):
    stated = np.radians(
        [[-170, 170], [-100, 160], [-70, 60], [-200, 200], [-140, 140], [-270, 270]]
    )
    np.testing.assert_allclose(arm.controller_limits_rad, stated)
    # The model's J3 = J3 + J2 ranges over the sum of both boxes; J2 is uncoupled.
    np.testing.assert_allclose(arm.joint_limits_rad[2], np.radians([-170, 220]))
    np.testing.assert_allclose(arm.joint_limits_rad[1], stated[1])
    np.testing.assert_allclose(arm.controller_box(), stated)


def test_a_pose_inside_the_models_box_but_beyond_the_controllers_j3_is_outside(arm):
    # J2 = 100, J3 = -80 (controller): model J3 = 20 deg, inside its box; J3 beyond -70.
    q_ctrl = np.radians([[0.0, 100.0, -80.0, 0.0, 0.0, 0.0], [0.0, 100.0, -60.0, 0.0, 0.0, 0.0]])
    q_model = arm.convention.to_model(q_ctrl)
    assert np.all(q_model[0] >= arm.joint_limits_rad[:, 0])
    assert np.all(q_model[0] <= arm.joint_limits_rad[:, 1])
    outside = arm.outside_limits(q_model)
    assert outside[0].tolist() == [False, False, True, False, False, False]
    assert not outside[1].any()
    row, what = arm.limit_breach(q_model)
    assert row == 0 and what.startswith("joint 3: -1.39626 rad outside [-1.22173, 1.0472]")
    with pytest.raises(planning.PlanError, match=r"plan row 0 joint 3: -1\.39626 rad outside"):
        planning.check_arm_limits(q_model, arm)


def test_a_session_beyond_the_controllers_j3_limit_is_refused_naming_it(arm, tmp_path):
    rng = np.random.default_rng(4)
    lo, hi = arm.controller_limits_rad.T
    q = rng.uniform(lo * 0.8, hi * 0.8, (20, 6))
    q[7, 1], q[7, 2] = np.radians(100.0), np.radians(-80.0)
    points = rng.uniform(-800, 800, (20, 3))
    table = session.to_table(q, points)
    meta = {"format": "calibrator.session", "version": 1, "frame": "tracker", "model": arm.name}
    pq.write_table(
        table.replace_schema_metadata({"calibrator": json.dumps(meta)}), tmp_path / "s.parquet"
    )
    with pytest.raises(session.SessionError, match=r"pose 7 \(row\) joint 3: -1\.39626 rad"):
        session.load(tmp_path / "s.parquet")


def test_coupled_limits_need_both_ends(tmp_path):
    shutil.copy(DATA / "fanuc-m20ia.urdf", tmp_path / "arm.urdf")
    text = DESCRIPTION.replace("  upper_deg: [170, 160, 60, 200, 140, 270]\n", "")
    (tmp_path / "arm.yaml").write_text(text)
    with pytest.raises(DescriptionError, match="lower_deg and upper_deg together"):
        robots.get(str(tmp_path / "arm.yaml"))


def test_an_uncoupled_arm_names_a_breach_in_its_controllers_angles():
    kuka = robots.get("kuka-kr6-r900")
    lo, hi = kuka.controller_box()[0]
    q_ctrl = np.zeros((1, 6))
    q_ctrl[0, 0] = hi + 0.1  # A1 beyond its upper limit: the model's joint 1 beyond its lower
    row, what = kuka.limit_breach(kuka.convention.to_model(q_ctrl))
    assert what == f"joint 1: {hi + 0.1:.6g} rad outside [{lo:.6g}, {hi:.6g}]"


def test_a_plan_for_the_coupled_arm_keeps_the_controllers_j3_limits(arm):
    from calibrator import cell as cells

    made = planning.make_checked(
        arm, 12, cells.Cell(tracker_at_mm=(4500.0, 0.0, 500.0)), (0.0, 0.0, 100.0), seed=2
    )
    q_ctrl = arm.convention.to_controller(made.plan.path_rad)
    lo, hi = arm.controller_limits_rad.T
    assert np.all((q_ctrl >= lo) & (q_ctrl <= hi))
    assert not arm.outside_limits(made.plan.path_rad).any()
