"""The verify run's pieces: plan, lead-in, registrations and the orientation figures."""

import numpy as np
import pytest

from calibrator import robots
from calibrator.model import frames, rotations
from calibrator.verify import pose as run

TOOL = frames.transform(translation=[0, 0, 100.0])


@pytest.fixture(scope="module")
def plan():
    from calibrator.simulate import SimWorld

    # Facing the simulated cell's tracker, as `calibrator verify` makes it.
    tracker = SimWorld.make("ur10e", 0).tracker_at_mm
    return run.make_plan(robots.get("ur10e"), TOOL, 3, tracker_at_mm=tracker)


def records(points, rotvecs=None):
    out = {}
    for i, p in enumerate(points):
        out[i] = {"pose": i, "status": "measured", "point_mm": list(p)}
        if rotvecs is not None:
            out[i]["rotvec_rad"] = list(rotvecs[i])
    return out


def test_plan_rows_follow_p5_to_p1_and_the_run_leads_in_from_p1(plan):
    assert plan.plan.shape == (15, 6) and plan.cycles == 3
    np.testing.assert_array_equal(plan.plan[0], plan.q_test[4])  # P5 first
    # Row 0 is led in from the last row: P1, as every later P5 is approached.
    np.testing.assert_array_equal(plan.plan[-1], plan.q_test[0])
    options = run.run_options(plan, readings=3)
    assert options.lead_in and options.need_poses == 15 and options.readings == 3


def test_fit_recovers_a_known_tracker_placement(plan):
    base2tracker = frames.transform(rotations.rotvec_to_matrix([0.1, -0.2, 2.5]), [2000, 300, -50])
    commanded = plan.desired[plan.test_pose - 1, :3, 3]
    rng = np.random.default_rng(0)
    attained = commanded + rng.normal(0, 0.01, commanded.shape)
    in_tracker = attained @ base2tracker[:3, :3].T + base2tracker[:3, 3]
    reg = run.fit(in_tracker, plan)
    truth = frames.invert(base2tracker)
    np.testing.assert_allclose(reg.tracker2base[:3, :3], truth[:3, :3], atol=1e-4)
    np.testing.assert_allclose(reg.tracker2base[:3, 3], truth[:3, 3], atol=0.1)  # 2 m lever
    poses, table = run.evaluate(in_tracker, None, plan, reg)
    assert max(p["AP_mm"] for p in poses) < 0.03
    np.testing.assert_allclose(table[["x_mm", "y_mm", "z_mm"]], attained, atol=0.03)


def test_orientation_figures_in_the_base_frame_of_a_six_dof_probe(plan):
    commanded = plan.desired[plan.test_pose - 1]
    # Every attained pose turned 0.01 deg about base x from the command, +-0.002 deg in turns.
    turn = np.deg2rad(0.01 + 0.002 * np.where(plan.cycle % 2 == 0, 1.0, -1.0))
    turn[plan.cycle == 3] = np.deg2rad(0.01)
    r = rotations.rotations_xyz(np.stack([turn, 0 * turn, 0 * turn], axis=1)) @ commanded[:, :3, :3]
    rotvecs = rotations.matrix_to_rotvec(r)
    pts, rv = run.points(records(commanded[:, :3, 3], rotvecs), plan)
    reg = run.surveyed(np.eye(4), "test")
    poses, table = run.evaluate(pts, rv, plan, reg)
    for p in poses:
        assert p["AP_mm"] == pytest.approx(0.0, abs=1e-9)
        # abar - a_c = 0.01 deg, S_a over (-0.002, +0.002, 0) deg = 0.002 deg
        assert p["APa_deg"] == pytest.approx(0.01, abs=1e-9)
        assert p["RPa_deg"] == pytest.approx(3 * 0.002, abs=1e-9)
        assert p["APb_deg"] == pytest.approx(0.0, abs=1e-9)
    doc = run.document(plan, poses, reg, info={})
    assert doc["orientation"].startswith("measured")
    assert {"a_rad", "b_rad", "c_rad"} <= set(table.columns)


def test_a_missing_visit_gives_no_figures(plan):
    commanded = plan.desired[plan.test_pose - 1, :3, 3]
    partial = records(commanded)
    partial[4]["status"] = "failed"
    with pytest.raises(run.CalibrationError, match="not measured: \\[4\\]"):
        run.points(partial, plan)


def test_a_resumed_run_leads_in_from_the_pose_before_the_first_one_left(plan, tmp_path):
    from contextlib import ExitStack

    from calibrator.acquire.run import MeasureRun
    from drivers.devices import Devices

    arm = robots.get("ur10e")

    def session(resume, stop_after):
        moves = []
        opened = Devices("sim", "sim://?noise=off").open(arm, 0, None, ExitStack())
        robot, tracker = opened.robot, opened.tracker
        options = run.run_options(plan, readings=1, resume=resume)
        output = tmp_path / "v.json"
        at = opened.tracker_at_mm
        with MeasureRun(robot, tracker, arm, options, output, tracker_at_mm=at) as mrun:
            mrun.connect()
            steer = robot.listener
            robot.listener = lambda pose: (moves.append(robot.actual_joints()), steer(pose))
            mrun.make_plan()
            mrun.open_journal()
            outcome = mrun.measure(should_stop=lambda: len(moves) > stop_after)
        return np.array(moves), outcome

    moves, outcome = session(False, 4)  # lead-in, then rows 0..3
    assert outcome.stopped == "interrupted before pose 4" and outcome.measured == [0, 1, 2, 3]
    np.testing.assert_array_equal(moves, np.concatenate([plan.q_test[:1], plan.plan[:4]]))
    moves, outcome = session(True, 99)
    assert outcome.stopped is None and outcome.measured == list(range(15))
    # Row 4 (P1 of cycle 1) is approached from row 3 (P2), as in a run never stopped.
    np.testing.assert_array_equal(moves, plan.plan[3:])


@pytest.mark.parametrize("name", ["ur5e", "ur10", "ur10e"])
def test_the_default_verify_plan_passes_the_cell_check_of_each_named_ur(name):
    from calibrator import cell as cells
    from calibrator import planning
    from calibrator.simulate import SimWorld

    arm = robots.get(name)
    tracker = SimWorld.make(arm.name, 0).tracker_at_mm
    vplan = run.make_plan(arm, TOOL, 30, tracker_at_mm=tracker)
    assert len(vplan.plan) == 150 and vplan.cube.side_mm >= 100.0
    # Every pose (acceptance, sight, plane...) and every move, the cycle's
    # P1 -> P5 (also the lead-in) included; the lead-in is a plan row already.
    vias = tuple([np.zeros((0, 6))] * len(vplan.plan))
    planning.check_plan(
        planning.Plan(vplan.plan, vias), arm, cells.Cell().with_tracker(tracker), TOOL[:3, 3]
    )
