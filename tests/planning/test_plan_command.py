"""``calibrator plan`` in-process and as a user runs it: the plan the library makes, refusals."""

import numpy as np
import pytest
from cli_kit import cli, one_line_error
from cli_process_kit import run_cli

from calibrator import planning, robots, session
from calibrator.model import frames
from calibrator.simulate import SIM_TRACKER_AT_MM

UR10E = robots.get("ur10e")
TOOL = frames.transform(translation=[0.0, 0.0, 100.0])
TOOL_MM = (0.0, 0.0, 100.0)


def test_plan_command_writes_the_plan_the_library_makes(tmp_path):
    from calibrator import cell as cells

    done = cli(
        "plan", "-o", "p.csv", "--poses", "12", "--candidates", "3000", "--sampling", "random",
        "--selection", "d-optimal", "--margin-deg", "10", "--tracker-at", "2500,400,300",
        "--acceptance-deg", "40", "--floor-mm", "-50", "--tool", "5,0,90", "--seed", "3",
        cwd=tmp_path,
    )  # fmt: skip
    assert done.code == 0, done.stderr
    cell = cells.Cell(tracker_at_mm=(2500.0, 400.0, 300.0), acceptance_deg=40.0,
                      mounting_plane_z_mm=-50.0)  # fmt: skip
    made = planning.make_checked(UR10E, 12, cell, (5.0, 0.0, 90.0), margin_rad=np.radians(10),
                              n_candidates=3000, method="random", seed=3,
                              speed_rad_s=0.5, accel_rad_s2=1.0)  # fmt: skip
    written = planning.read_plan(tmp_path / "p.csv")
    np.testing.assert_array_equal(written.path_rad, made.plan.path_rad)
    lines = done.stdout.splitlines()
    assert lines[0].startswith(f"candidates: 3000, dropped {sum(made.dropped.values())} (")
    # At measure's default speed and acceleration: the time measure will take.
    assert lines[1].startswith(
        f"estimated cell time {made.ordered_time} at 0.5 rad/s, 1 rad/s^2 (measure's --speed, "
    )
    assert lines[2] == (
        "wrote p.csv: 12 poses"
        + (f" and {made.plan.n_vias} via rows" if made.plan.n_vias else "")
        + f", d-optimal selection, log det(J^T J) {planning.log_det(made.blocks):.2f}, "
        f"smallest singular value {planning.min_singular(made.blocks):.4g}"
    )


def test_plan_command_without_a_tracker_aims_at_the_simulated_cells_and_says_so(tmp_path):
    from calibrator import cell as cells

    given = planning.sample(planning.joint_box(UR10E.joint_limits_rad, 0.1), 3000, "random", seed=8)
    planning.write_plan(tmp_path / "c.csv", planning.Plan(given))
    done = cli("plan", "--from", "c.csv", "--poses", "9", "--selection", "first", cwd=tmp_path)
    assert done.code == 0, done.stderr
    assert "9 poses" in done.stdout and ", first selection, log det(J^T J) " in done.stdout
    assert "the poses face the simulated cell's tracker at 2500,400,300 mm" in done.stderr
    cell = cells.Cell(tracker_at_mm=tuple(SIM_TRACKER_AT_MM))
    expected = planning.make_checked(UR10E, 9, cell, (0.0, 0.0, 100.0), candidates=given,
                                  selection="first")  # fmt: skip
    written = planning.read_plan(tmp_path / "plan.csv")
    np.testing.assert_array_equal(written.path_rad, expected.plan.path_rad)
    assert written.origin.tracker_at_mm == (2500.0, 400.0, 300.0)


def test_plan_command_refuses_to_overwrite_its_candidates(tmp_path):
    planning.write_plan(tmp_path / "c.csv", planning.Plan(np.zeros((3, 6))))
    before = (tmp_path / "c.csv").read_bytes()
    done = cli("plan", "--from", "c.csv", "-o", "c.csv", cwd=tmp_path)
    assert "c.csv" in one_line_error(done)
    assert (tmp_path / "c.csv").read_bytes() == before
    done = cli("plan", "--tool", "0,0", cwd=tmp_path)
    assert (
        one_line_error(done)
        == "calibrator: error: --tool: needs X,Y,Z (three numbers, mm), got '0,0'"
    )
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.csv"]


def test_plan_cli_writes_a_plan_measure_then_uses(tmp_path):
    made = run_cli(
        "plan", "-o", "plan.csv", "--poses", "10", "--tracker-at", "2500,400,300", cwd=tmp_path
    )
    assert made.returncode == 0, made.stderr
    assert "wrote plan.csv: 10 poses" in made.stdout and "d-optimal selection" in made.stdout
    q = planning.read_plan(tmp_path / "plan.csv").q_rad
    assert q.shape == (10, 6)
    done = run_cli("measure", "--plan", "plan.csv", "-o", "s.parquet", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    loaded = session.load(tmp_path / "s.parquet")
    np.testing.assert_allclose(loaded.array(session.JOINT_COLUMNS), q, atol=1e-12)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (("plan", "--tracker-at", "1,2"), "--tracker-at: needs X,Y,Z"),
        (("plan", "-o", "nodir/p.csv"), "folder nodir does not exist"),
        (("plan", "--from", "missing.csv"), "cannot read plan missing.csv"),
        (("measure", "--plan", "bad.csv"), "plan row 1 joint 3"),
        (("measure", "--plan", "short.csv"), "the free parameters need at least"),
        (("measure", "--robot", "ftp://x"), "--robot: unknown robot"),
        (("measure", "--tracker", "gopher://x"), "--tracker: unknown tracker"),
        (("measure", "--speed", "3"), "--speed 3.0 rad/s outside"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(tmp_path, args, message):
    # Distinct poses (a repeated pose is refused by the reader before anything else).
    steps = 0.01 * np.arange(10)[:, None]
    bad = np.array([[0.0] * 6, [0, 0, 4.0, 0, 0, 0]] * 5) + steps * [1, 1, 0, 1, 1, 1]
    planning.write_plan(tmp_path / "bad.csv", planning.Plan(bad))
    planning.write_plan(tmp_path / "short.csv", planning.Plan(0.01 * np.arange(18.0).reshape(3, 6)))
    done = run_cli(*args, cwd=tmp_path)
    assert done.returncode == 2, done.stderr
    assert message in done.stderr and done.stderr.count("\n") == 1, done.stderr
    assert not list(tmp_path.glob("*.journal")) and not list(tmp_path.glob(".*tmp"))


def test_the_plan_size_for_three_values_per_parameter_after_the_hold_out():
    """30 poses of a UR10e in the tracker frame leave 2.9 values per parameter: 31 leave 3."""
    from calibrator.identify import freeset, identifiability

    mdh = robots.get("ur10e").mdh
    n = freeset.poses_for(mdh, "tracker", False, 0.2)
    free = len(freeset.decide(mdh, "tracker", False, False).names)
    assert free == 25 and n == 31
    for poses, warned in ((n, False), (n - 1, True)):
        fit = poses - round(0.2 * poses)
        assert (3 * fit / free < identifiability.MIN_VALUES_PER_PARAMETER) is warned, poses
    assert freeset.poses_for(mdh, "tracker", False, 0.2, orientation=True) < n
    assert planning.min_poses(mdh) == -(-free // 3)  # both from the one free-set decision
