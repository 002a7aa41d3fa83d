"""``program --model ARM`` writes the controller's joint angles, read back to the model's exactly.

A KUKA's A1 and A6 turn the other way to the description's joints, a Fanuc's
J3 is read relative to J2: the program a pendant runs must state the angles
the controller uses, and a plan made for that arm, written and parsed back
(through the description's convention), is the plan.
"""

import numpy as np
import pytest
from cli_kit import cli
from grammar_kit import PARSERS

from calibrator import cell as cells
from calibrator import planning, robots

ARMS = [
    ("kuka-kr6-r900", "cal.src", "krl"),
    ("abb-irb4600-60-205", "cal.mod", "rapid"),
    ("fanuc-m20ia", "cal.ls", "fanuc-ls"),
]


@pytest.fixture(scope="module", params=ARMS, ids=[a[0] for a in ARMS])
def made(request, tmp_path_factory):
    name, output, fmt = request.param
    arm = robots.get(name)
    reach = float(np.abs(arm.mdh[:, [0, 3]]).sum())
    at = (2.2 * reach, 0.3 * reach, 300.0)
    plan = planning.make_checked(arm, 10, cells.Cell(tracker_at_mm=at), (0, 0, 100), seed=0).plan
    folder = tmp_path_factory.mktemp(name)
    planning.write_plan(folder / "plan.csv", plan)
    done = cli("program", "plan.csv", "--model", name, "-o", output, cwd=folder)
    assert done.code == 0, done.stderr
    return arm, plan, PARSERS[fmt]((folder / output).read_text())


def test_the_program_reads_back_to_the_plan_through_the_convention(made):
    arm, plan, parsed = made
    ctrl = np.array(parsed.targets())  # home, every via and pose in order, home
    model = arm.convention.to_model(ctrl)
    np.testing.assert_allclose(model[1:-1], plan.path_rad, rtol=0, atol=2e-8)


def test_the_program_states_controller_angles_not_model_angles(made):
    arm, plan, parsed = made
    ctrl = np.array(parsed.targets())[1:-1]
    expected = arm.convention.to_controller(plan.path_rad)
    np.testing.assert_allclose(ctrl, expected, rtol=0, atol=2e-8)
    if not arm.convention.is_identity:
        # The convention changes what is written: model angles would be wrong here.
        assert np.abs(ctrl - plan.path_rad).max() > 1e-3


def test_written_controller_angles_stay_inside_the_limits_when_read_back(made):
    arm, _, parsed = made
    model = arm.convention.to_model(np.array(parsed.targets()))
    lo, hi = arm.joint_limits_rad[:, 0], arm.joint_limits_rad[:, 1]
    assert np.all(model >= lo - 1e-12) and np.all(model <= hi + 1e-12)
