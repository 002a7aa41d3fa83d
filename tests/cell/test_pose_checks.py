"""Whole-arm pose checks: one known-bad pose per check, each confirmed independently."""

import numpy as np
import pytest

from calibrator import cell, robots
from calibrator.cell import checks
from calibrator.model import kinematics

UR10E = robots.get("ur10e")
TOOL_MM = (0.0, 0.0, 100.0)
D = np.radians


def _checker(**kwargs):
    return cell.checker(cell.arm_geometry("ur10e", UR10E.mdh, TOOL_MM), cell.Cell(**kwargs))


def _reasons(chk, q_deg):
    faults = cell.pose_faults(chk, D(np.asarray(q_deg, dtype=float)))[0]
    return {r for r, bad in zip(cell.REASONS, faults, strict=True) if bad}


def _frames(q_deg):
    _, frames = kinematics.chain(UR10E.mdh, D(np.asarray([q_deg], dtype=float)), all_frames=True)
    return frames[0]


SAFE = [0.0, -90.0, 60.0, -150.0, -90.0, 0.0]  # upper arm up, forearm forward, tool along -x


def test_a_safe_pose_passes_every_check():
    chk = _checker(tracker_at_mm=(-3000.0, -174.0, 1200.0))
    assert _reasons(chk, SAFE) == set()


def test_elbow_under_the_mounting_plane_is_refused():
    # The pose the issue found: the elbow about 420 mm under the plane.
    q = [-61, 79, -159, -34, 159, -73]
    assert _frames(q)[2, 2, 3] < -300.0  # the elbow joint's origin, independently
    chk = _checker()
    assert _reasons(chk, q) == {"below mounting plane"}
    assert checks.describe(chk, D(np.array(q, float)), "below mounting plane").startswith("elbow")
    # On a pedestal 1 m high the elbow clears the floor (the pedestal is the base's column).
    assert "below mounting plane" not in _reasons(_checker(mounting_plane_z_mm=-1000.0), q)


def test_wrist_into_the_base_is_refused():
    q = [-10, -63, 169, -47, -140, -54]
    wrist3 = _frames(q)[5, :3, 3]
    # Independently: wrist 3's origin is lower than the shoulder and close to the base axis.
    assert wrist3[2] < UR10E.mdh[0, 3] and np.hypot(*wrist3[:2]) < 95.0 + 50.0 + 60.0
    chk = _checker()
    assert "into the base" in _reasons(chk, q)
    assert checks.describe(chk, D(np.array(q, float)), "into the base").startswith("wrist 3")


def test_forearm_folded_into_the_upper_arm_is_refused():
    chk = _checker()
    folded = [0, -90, 175, 0, 0, 0]
    assert "self collision" in _reasons(chk, folded)
    assert "upper arm" in checks.describe(chk, D(np.array(folded, float)), "self collision")
    # Folded less, the same arm is clear.
    assert "self collision" not in _reasons(chk, [0, -90, 120, 0, 0, 0])


def test_upper_arm_between_tracker_and_reflector_blocks_the_line_of_sight():
    q = D(np.array([[0.0, -60.0, 100.0, -130.0, -90.0, 0.0]]))
    base2flange, frames = kinematics.chain(UR10E.mdh, q, all_frames=True)
    reflector = base2flange[0, :3, :3] @ TOOL_MM + base2flange[0, :3, 3]
    # The middle of the upper arm tube: halfway between shoulder and elbow, at the shoulder offset.
    axis = frames[0, 1, :3, 2]
    middle = 0.5 * (frames[0, 1, :3, 3] + frames[0, 2, :3, 3]) + 176.0 * axis
    behind = reflector + 3.0 * (middle - reflector)  # the tracker beyond the upper arm
    chk = _checker(tracker_at_mm=tuple(behind), acceptance_deg=90.0)
    assert cell.checks.sight_faults(chk, q)[0]
    # On the other side of the reflector, away from the arm, the beam is clear.
    front = reflector - 3.0 * (middle - reflector)
    chk = _checker(tracker_at_mm=tuple(front), acceptance_deg=90.0)
    assert not cell.checks.sight_faults(chk, q)[0]


def test_a_box_obstacle_around_the_tool_is_refused():
    base2flange = kinematics.chain(UR10E.mdh, D(np.array([SAFE])))[0]
    tool = base2flange[:3, :3] @ TOOL_MM + base2flange[:3, 3]
    box = cell.Box("fixture", tuple(tool + [-50, -50, -200]), tuple(tool + [50, 50, -30]))
    chk = _checker(boxes=(box,))
    assert _reasons(chk, SAFE) == {"obstacle"}
    assert "'fixture'" in checks.describe(chk, D(np.array(SAFE)), "obstacle")
    far = cell.Box("fixture", tuple(tool + [500, 500, -200]), tuple(tool + [600, 600, -30]))
    assert _reasons(_checker(boxes=(far,)), SAFE) == set()


def test_a_tripod_cylinder_and_a_beam_through_it():
    base2flange = kinematics.chain(UR10E.mdh, D(np.array([SAFE])))[0]
    tool = base2flange[:3, :3] @ TOOL_MM + base2flange[:3, 3]
    tracker = tool - np.array([2500.0, 0.0, 0.0])
    post = cell.Cylinder("post", tuple(tool[:2] - [1200.0, 0.0]), 100.0, -1000.0, 3000.0)
    chk = _checker(cylinders=(post,), tracker_at_mm=tuple(tracker), acceptance_deg=90.0)
    assert "line of sight" in _reasons(chk, SAFE)


def test_tracker_too_close():
    with pytest.raises(cell.CellError, match="inside the ur10e's reach envelope"):
        cell.check_tracker_placement(_checker(tracker_at_mm=(300.0, 0.0, 0.0)))
    cell.check_tracker_placement(_checker(tracker_at_mm=(2500.0, 400.0, 300.0)))
    # A tracker outside the envelope, but a reflector nearer than its minimum range.
    base2flange = kinematics.chain(UR10E.mdh, D(np.array([SAFE])))[0]
    tool = base2flange[:3, :3] @ TOOL_MM + base2flange[:3, 3]
    near = _checker(tracker_at_mm=tuple(tool - [700.0, 0, 0]), acceptance_deg=90.0)
    assert _reasons(near, SAFE) == {"tracker range"}
    assert (
        _reasons(
            _checker(
                tracker_at_mm=tuple(tool - [700.0, 0, 0]), acceptance_deg=90.0, min_range_mm=500.0
            ),
            SAFE,
        )
        == set()
    )


def test_reflector_turned_away_from_the_tracker():
    chk = _checker(tracker_at_mm=(0.0, 0.0, 4000.0))  # above; the tool points along -x
    assert _reasons(chk, SAFE) == {"acceptance angle"}


@pytest.mark.parametrize("model", ["ur5e", "ur10", "ur10e", "er10l-c10"])
def test_every_named_arm_has_a_model_whose_stretched_upright_pose_is_clear(model):
    robot = robots.get(model)
    geometry = cell.arm_geometry(model, robot.mdh, TOOL_MM)
    chk = cell.checker(geometry, cell.Cell())
    upright = np.zeros(6)
    upright[1:3] = geometry.upright_rad
    assert not cell.pose_faults(chk, upright).any()
    # Folded hard at the elbow, every arm hits itself or its base.
    folded = upright.copy()
    folded[2] += np.radians(178.0)
    assert cell.pose_faults(chk, folded).any()
