"""Motion checks along moveJ's joint-space line, move times, and the order of a plan."""

import numpy as np
import pytest

from calibrator import cell, planning, robots
from calibrator.model import kinematics

UR10E = robots.get("ur10e")
TOOL_MM = (0.0, 0.0, 100.0)
D = np.radians


def _checker(**kwargs):
    return cell.checker(cell.arm_geometry("ur10e", UR10E.mdh, TOOL_MM), cell.Cell(**kwargs))


# Two poses 20 deg apart at wrist 1, with the forearm level at shoulder height; moveJ
# turns wrist 1 the long way (340 deg), through the wrist pointing down into the table.
QA = D(np.array([0.0, 0.0, 0.0, -170.0, 90.0, 0.0]))
QB = D(np.array([0.0, 0.0, 0.0, 170.0, 90.0, 0.0]))
FLANGE2TOOL = np.eye(4)
FLANGE2TOOL[:3, 3] = TOOL_MM


def test_a_bad_motion_between_two_safe_poses_is_found():
    chk = _checker()
    assert not cell.checks.collision_faults(chk, np.array([QA, QB])).any()
    faults = cell.motion_faults(chk, QA, QB)[0]
    assert faults[0] and cell.MOTION_REASONS[0] == "below mounting plane"
    # Independently: the tool point on the joint-space line goes under the plane.
    tool_z = kinematics.forward(UR10E.mdh, np.linspace(QA, QB, 721), FLANGE2TOOL)[:, 2, 3]
    assert tool_z.min() < 0.0 < tool_z[[0, -1]].min()
    # Going the short way (through 180 deg) is safe.
    short = QB.copy()
    short[3] = QA[3] - D(20.0)
    assert not cell.motion_faults(chk, QA, short).any()


def test_motion_samples_are_at_most_the_step_apart_and_keep_both_ends():
    q, owner, step = cell.checks.motion_samples(np.array([QA, QA]), np.array([QB, QA + 0.005]))
    first = q[owner == 0]
    np.testing.assert_allclose(first[[0, -1]], [QA, QB])
    assert np.abs(np.diff(first, axis=0)).max() <= cell.checks.MOTION_STEP_RAD + 1e-12
    np.testing.assert_allclose(step[owner == 0][0], np.abs(QB - QA) / (len(first) - 1))
    assert (owner == 1).sum() == 2  # a short move: its two ends


def test_plan_check_names_the_bad_motion_and_passes_once_a_via_avoids_it():
    cell_ = cell.Cell()
    bad = planning.Plan(np.array([QA, QB]))
    with pytest.raises(cell.CellError, match="motion from pose 0 to pose 1: below mounting plane"):
        planning.check_plan(bad, UR10E, cell_, TOOL_MM)
    # Lift the arm upright, turn the wrist up there, come down.
    vias = np.array([QA, QB])
    vias[:, 1] = -np.pi / 2
    good = planning.Plan(np.array([QA, QB]), (np.zeros((0, 6)), vias))
    planning.check_plan(good, UR10E, cell_, TOOL_MM)
    assert good.path_rad.shape == (4, 6) and good.n_vias == 2


def test_plan_check_names_the_bad_pose():
    elbow_down = D(np.array([-61, 79, -159, -34, 159, -73.0]))
    safe = D(np.array([0.0, -90.0, 60.0, -150.0, -90.0, 0.0]))
    with pytest.raises(cell.CellError, match="^plan pose 1: below mounting plane: elbow"):
        planning.check_plan(
            planning.Plan(np.array([safe, elbow_down])), UR10E, cell.Cell(), TOOL_MM
        )


def test_trapezoid_times():
    # 2 rad at 1 rad/s and 2 rad/s^2: 0.5 s ramps, 1.5 rad cruise: 2.5 s.
    np.testing.assert_allclose(cell.timing.trapezoid_time(2.0, 1.0, 2.0), 2.5)
    # 0.1 rad never reaches the cap: a triangle, 2 sqrt(0.1 / 2).
    np.testing.assert_allclose(cell.timing.trapezoid_time(0.1, 1.0, 2.0), 2 * np.sqrt(0.05))
    # Continuous at the corner v^2/a.
    at = cell.timing.trapezoid_time([0.5 - 1e-9, 0.5 + 1e-9], 1.0, 2.0)
    np.testing.assert_allclose(at[0], at[1], atol=1e-6)
    # The slowest joint leads.
    assert cell.move_times(np.zeros(6), np.array([0.1, 2.0, 0, 0, 0, -0.3]), 1.0, 2.0) == 2.5


def test_order_is_a_permutation_and_beats_a_scrambled_order():
    rng = np.random.default_rng(3)
    q = rng.uniform(-2, 2, (40, 6))
    times = cell.time_matrix(q, 1.0, 2.0)
    order = cell.order_poses(times)
    assert sorted(order.tolist()) == list(range(40))
    scrambled = cell.timing.path_time(times, np.arange(40))
    assert cell.timing.path_time(times, order) < 0.8 * scrambled


def test_order_avoids_forbidden_moves():
    q = np.zeros((6, 6))
    q[:, 0] = np.arange(6) * 0.1  # a row of poses: the best path goes along it
    times = cell.time_matrix(q, 1.0, 2.0)
    times[2, 3] = times[3, 2] = np.inf
    order = cell.order_poses(times)
    pairs = {frozenset(p) for p in zip(order[:-1], order[1:], strict=True)}
    assert frozenset((2, 3)) not in pairs


def test_cell_time_adds_moves_settle_and_readings():
    path = np.array([np.zeros(6), np.full(6, 2.0)])
    t = cell.cell_time(path, 2, 1.0, 2.0, settle_s=0.5, readings=20, rate_hz=10.0)
    assert (t.moves_s, t.settle_s, t.readings_s, t.total_s) == (2.5, 1.0, 4.0, 7.5)
    assert str(t) == "8 s (moves 2 s, settle 1 s, readings 4 s)"
    est = planning.estimate(
        planning.Plan(path), UR10E, 5.0, 9.0, settle_s=0.5, readings=20, rate_hz=10
    )
    assert est == t  # speed and acceleration lowered to the model's caps


@pytest.mark.parametrize("model", ["ur10e", "ur5e", "er10l-c10"])
def test_swept_bound_covers_how_far_capsules_move_between_samples(model):
    # The clearance a motion sample adds must cover the farthest any capsule point
    # moves over one step: checked on 2000 random steps, end points and mid points.
    robot = robots.get(model)
    geometry = cell.arm_geometry(model, robot.mdh, (30.0, -20.0, 150.0))
    chk = cell.checker(geometry, cell.Cell())
    rng = np.random.default_rng(5)
    q = rng.uniform(-np.pi, np.pi, (2000, 6))
    step = rng.uniform(-1.0, 1.0, (2000, 6)) * cell.checks.MOTION_STEP_RAD
    a, b = cell.place(geometry, q), cell.place(geometry, q + step)
    moved = np.linalg.norm(b - a, axis=-1).max(axis=-1)  # (N, K) ends
    mid = np.linalg.norm(b.mean(axis=2) - a.mean(axis=2), axis=-1)
    bound = np.abs(step) @ chk.levers_mm  # (N, K)
    assert np.all(np.maximum(moved, mid) <= bound + 1e-9)
    # And the bound is not absurd: typically within 4 times the real motion.
    assert np.median(bound / np.maximum(moved, 1e-9)) < 4.0
