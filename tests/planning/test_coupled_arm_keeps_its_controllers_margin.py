"""A plan for a coupled arm keeps the joint margin from the controller's limits too.

FANUC measures J3 from the horizon: the model's joint 3 is J3 + J2, and the
controller's J3 limits (stated in the description) cut the model's box. The
planner samples in the model's box, so :func:`calibrator.planning.make_checked`
must drop the candidates within the margin of a controller limit, as it does
for the model's: ``tests/robots/test_controller_limits.py`` checks only that a
plan stays inside the controller's limits, which a pose 2 deg from one is.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from calibrator import cell as cells
from calibrator import planning, robots

DATA = Path(robots.__file__).with_name("data")
TOOL_MM = (0.0, 0.0, 100.0)
CELL = cells.Cell(tracker_at_mm=(4500.0, 0.0, 500.0))

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


@pytest.fixture(scope="module")
def arm(tmp_path_factory):
    folder = tmp_path_factory.mktemp("coupled")
    shutil.copy(DATA / "fanuc-m20ia.urdf", folder / "arm.urdf")
    (folder / "arm.yaml").write_text(DESCRIPTION)
    return robots.get(str(folder / "arm.yaml"))


def test_a_candidate_within_the_margin_of_the_controllers_j3_limit_is_dropped(arm):
    made = planning.make_checked(arm, 12, CELL, TOOL_MM, seed=2)
    good = made.plan.q_rad
    # One more candidate: a chosen pose with the controller's J3 at 57 deg, 3 deg from
    # its 60-deg limit (inside the limit, within the 5-degree margin); the model's
    # joint 3 (J3 + J2) stays far inside the model's box.
    near = arm.convention.to_controller(good[:1])
    near[0, 2] = np.radians(57.0)
    near_model = arm.convention.to_model(near)
    assert not arm.outside_limits(near_model).any()
    box = planning.joint_box(arm.joint_limits_rad, np.radians(5.0))
    assert np.all((near_model >= box[:, 0]) & (near_model <= box[:, 1]))
    candidates = np.vstack([good, near_model])
    again = planning.make_checked(arm, 12, CELL, TOOL_MM, seed=2, candidates=candidates)
    assert again.dropped["outside joint limits less margin"] == 1
    assert not np.any(np.all(np.isclose(again.plan.q_rad, near_model), axis=1))
    with pytest.raises(planning.PlanError) as caught:
        planning.make_checked(arm, 13, CELL, TOOL_MM, seed=2, candidates=candidates)
    assert str(caught.value).startswith(
        "only 12 of 13 candidates pass the cell's checks (outside joint limits less margin 1); "
        "13 asked"
    )
