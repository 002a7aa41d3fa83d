"""Pose plans piece by piece (calibrator/plan.py) and ``calibrator plan`` run in-process.

Each check compares with a value found another way: a determinant or
singular value of a matrix built by hand, the arm's own forward kinematics,
the SHA-256 of the plan's bytes as the journal format defines it, or the
plan library called with the options the command was given.
"""

import hashlib
import struct

import numpy as np
import pytest
from cli_kit import cli, one_line_error

from calibrator import plan as plans
from calibrator import robots
from calibrator.model import frames, kinematics
from calibrator.simulate import SIM_TRACKER_AT_MM

UR10E = robots.get("ur10e")
TOOL = frames.transform(translation=[0.0, 0.0, 100.0])
LIMITS = np.tile([-2.0, 3.0], (6, 1))


# ---------------------------------------------------------------- criteria


def test_log_det_and_smallest_singular_value_of_a_known_matrix():
    blocks = np.zeros((2, 3, 4))
    blocks[0] = np.diag([1.0, 2.0, 3.0, 0.0])[:3]  # pose 0 sees parameters 0-2
    blocks[1, 0, 3] = 0.5  # pose 1 sees parameter 3
    # J^T J = diag(1, 4, 9, 0.25)
    assert plans.log_det(blocks) == pytest.approx(np.log(1 * 4 * 9 * 0.25), abs=1e-12)
    assert plans.min_singular(blocks) == pytest.approx(0.5, abs=1e-12)
    assert plans.min_singular(blocks[:, :, :3]) == pytest.approx(1.0, abs=1e-12)


def test_a_singular_design_scores_minus_infinity():
    blocks = np.zeros((2, 3, 4))
    blocks[:, :, :3] = np.eye(3)  # parameter 3 is never seen
    assert plans.log_det(blocks) == -np.inf
    assert plans.min_singular(blocks) == pytest.approx(0.0, abs=1e-12)


def test_a_design_singular_up_to_rounding_scores_minus_infinity_too():
    # Parameter 3 moves the point exactly as 0.1 p0 + 0.3 p1 would: J^T J is singular, and
    # its rounded determinant comes out tiny and negative (slogdet's sign -1).
    j = np.random.default_rng(0).normal(size=(18, 3))
    blocks = np.column_stack([j, j[:, 0] * 0.1 + j[:, 1] * 0.3]).reshape(6, 3, 4)
    assert np.linalg.slogdet(blocks.reshape(-1, 4).T @ blocks.reshape(-1, 4))[0] == -1
    assert plans.log_det(blocks) == -np.inf


def test_observability_names_the_free_parameters_and_scales_angles():
    rng = np.random.default_rng(1)
    q = rng.uniform(-np.pi, np.pi, (20, 6))
    obs = plans.observability(UR10E.mdh, q, TOOL)
    assert obs.blocks.shape == (20, 3, len(obs.names))
    # A length parameter: its column is the tool point's move per mm, an O(1) number;
    # an angle column is mm per rad divided by the 1000 mm scale, also O(1).
    norms = np.linalg.norm(obs.blocks, axis=(0, 1)) / np.sqrt(20)
    assert np.all(norms > 0.05) and np.all(norms < 3.0)


def test_the_fewest_poses_follow_the_free_parameters():
    # Three position rows per pose: ceil(free parameters / 3).
    need = plans.min_poses(UR10E.mdh)
    rng = np.random.default_rng(0)
    q = rng.uniform(-np.pi, np.pi, (64, 6))
    assert need == -(-len(plans.observability(UR10E.mdh, q).names) // 3)
    assert plans.min_poses(UR10E.mdh, tool_known=True) < need
    assert plans.min_poses(UR10E.mdh, "base") < need


# ---------------------------------------------------------------- validate


def test_a_plan_on_its_limits_is_valid_and_comes_back_as_floats():
    q = [[-2, 3, 0, 0, 0, 0]] * 4 + [[3, -2, 0, 0, 0, 0]]  # integers, on the limits
    out = plans.validate(q, LIMITS.astype(int), need=5)
    assert out.dtype == float and out.shape == (5, 6)
    np.testing.assert_array_equal(out, q)


@pytest.mark.parametrize(
    ("q", "message"),
    [
        (np.zeros((5, 5)), r"a plan needs 6 joint angles per pose, got shape \(5, 5\)"),
        (np.zeros(6), r"got shape \(6,\)"),
        (np.zeros((2, 6, 1)), r"got shape \(2, 6, 1\)"),
    ],
)
def test_a_plan_of_the_wrong_shape_is_refused(q, message):
    with pytest.raises(plans.PlanError, match=message):
        plans.validate(q, LIMITS)


@pytest.mark.parametrize(
    ("row", "joint", "value"),
    [(3, 0, -2.0000001), (1, 5, 3.0000001), (4, 2, np.nan)],
)
def test_a_joint_past_its_limit_is_named(row, joint, value):
    q = np.zeros((6, 6))
    q[row, joint] = value
    q[5, 1] = 99.0  # a later row is not the one named
    with pytest.raises(plans.PlanError) as exc:
        plans.validate(q, LIMITS)
    assert str(exc.value) == (
        f"plan row {row} joint {joint + 1}: {value:.6g} rad outside [-2, 3]; nothing moved"
    )


def test_exactly_the_needed_poses_are_enough():
    assert len(plans.validate(np.zeros((9, 6)), LIMITS, need=9)) == 9
    with pytest.raises(plans.PlanError, match="^plan has 8 poses; the free .* at least 9$"):
        plans.validate(np.zeros((8, 6)), LIMITS, need=9)


# ---------------------------------------------------------------- digest and files


def test_the_digest_is_the_sha256_of_the_little_endian_doubles_row_by_row():
    q = np.arange(12, dtype=float).reshape(2, 6) / 7
    expected = hashlib.sha256(struct.pack("<12d", *q.ravel()))
    assert plans.digest(q) == expected.hexdigest()
    assert plans.digest(q.astype(">f8")) == plans.digest(np.asfortranarray(q)) == plans.digest(q)
    assert plans.digest(np.arange(12).reshape(2, 6)) == plans.digest(np.arange(12.0).reshape(2, 6))
    nudged = q.copy()
    nudged[1, 5] = np.nextafter(nudged[1, 5], 9)
    assert plans.digest(nudged) != plans.digest(q)


def test_a_written_plan_reads_back_exactly(tmp_path):
    q = np.random.default_rng(3).uniform(-3, 3, (7, 6))
    plans.write_csv(tmp_path / "p.csv", q)
    lines = (tmp_path / "p.csv").read_text().split("\n")
    assert lines[0] == "pose,q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,q6_rad"
    assert [line.split(",")[0] for line in lines[1:-1]] == [str(i) for i in range(7)]
    assert lines[-1] == ""
    np.testing.assert_array_equal(plans.read_csv(tmp_path / "p.csv"), q)


def test_a_plan_in_degrees_is_read_in_radians(tmp_path):
    (tmp_path / "d.csv").write_text(
        "q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n180,90,-45,0,30,360\n"
    )
    np.testing.assert_allclose(
        plans.read_csv(tmp_path / "d.csv"),
        [[np.pi, np.pi / 2, -np.pi / 4, 0, np.pi / 6, 2 * np.pi]],
        rtol=1e-15,
    )
    both = "q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,q6_rad,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n"
    (tmp_path / "b.csv").write_text(both + "1,1,1,1,1,1,9,9,9,9,9,9\n")
    with pytest.raises(plans.PlanError, match="both q1_rad..q6_rad and q1_deg..q6_deg"):
        plans.read_csv(tmp_path / "b.csv")


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (None, "^cannot read plan .*p.csv: "),
        (b"\xff\xfe\x00", "^cannot read plan "),
        ("q1_rad,q2_rad,q3_rad,q4_rad,q5_rad\n1,2,3,4,5\n", "needs columns q1_rad,q2_rad,"),
        ("", "needs columns q1_rad,.*,q6_rad \\(or q1_deg..q6_deg\\)$"),
        ("q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,q6_rad\n", ": the plan has no poses$"),
        (
            "q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,q6_rad\n1,2,3,4,5,x\n",
            "line 2, q6_rad: 'x' is not a decimal number$",
        ),
        (
            "q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,q6_rad\n1,2,3,4,5\n",
            "line 2, q6_rad: '' is not a decimal number$",
        ),
        (
            "q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,q6_rad\n1,2,3,4,5,nan\n",
            "line 2, q6_rad: 'nan' is not a decimal",
        ),
        (
            "q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n1,2,3,4,5,-inf\n",
            "line 2, q6_deg: '-inf' is not a decimal",
        ),
    ],
)
def test_a_bad_plan_file_is_refused_naming_the_problem(tmp_path, text, message):
    path = tmp_path / "p.csv"
    if isinstance(text, bytes):
        path.write_bytes(text)
    elif text is not None:
        path.write_text(text)
    with pytest.raises(plans.PlanError, match=message):
        plans.read_csv(path)


# ---------------------------------------------------------------- making plans


def test_the_sampling_box_is_the_limits_within_half_a_turn_less_the_margin():
    limits = np.array([[-7, 7], [-1, 2], [-3, 0.5], [-1, 1], [0, 4], [-4, 0]], float)
    box = plans.joint_box(limits, 0.25)
    expected = [
        [-np.pi + 0.25, np.pi - 0.25],
        [-0.75, 1.75],
        [-2.75, 0.25],
        [-0.75, 0.75],
        [0.25, np.pi - 0.25],
        [-np.pi + 0.25, -0.25],
    ]
    np.testing.assert_allclose(box, expected, rtol=1e-15)
    with pytest.raises(plans.PlanError, match="a joint margin of 57.3 deg leaves no joint range"):
        plans.joint_box(limits, 1.0)  # joint 4 has 2 rad: exactly nothing left


@pytest.mark.parametrize("method", ["halton", "random"])
def test_samples_fill_the_box_and_repeat_with_the_seed(method):
    box = plans.joint_box(LIMITS, 0.1)
    q = plans.sample(box, 400, method, seed=5)
    assert q.shape == (400, 6)
    assert np.all(q >= box[:, 0]) and np.all(q <= box[:, 1])
    spread = (q.max(axis=0) - q.min(axis=0)) / (box[:, 1] - box[:, 0])
    assert np.all(spread > 0.95)  # the whole box, not a corner of it
    np.testing.assert_array_equal(q, plans.sample(box, 400, method, seed=5))
    assert not np.array_equal(q, plans.sample(box, 400, method, seed=6))


def test_halton_samples_are_more_even_than_random_ones():
    box = np.tile([0.0, 1.0], (6, 1))
    counts = [
        np.histogram(plans.sample(box, 512, m, seed=1)[:, 0], bins=8, range=(0, 1))[0]
        for m in ("halton", "random")
    ]
    assert np.ptp(counts[0]) <= 2 < np.ptp(counts[1])
    with pytest.raises(plans.PlanError, match="unknown sampling method 'sobol'; use halton or"):
        plans.sample(box, 4, "sobol")


def facing(q, tracker_at):
    """Angle (rad) between the tool's z axis and the line to the tracker, base frame."""
    tool = kinematics.chain(UR10E.mdh, q) @ TOOL
    to_tracker = tracker_at - tool[:, :3, 3]
    cos = np.einsum("nj,nj->n", tool[:, :3, 2], to_tracker) / np.linalg.norm(to_tracker, axis=1)
    return np.arccos(np.clip(cos, -1, 1)), tool[:, 2, 3]


def test_feasible_keeps_exactly_the_poses_facing_the_tracker_above_the_floor():
    q = plans.sample(plans.joint_box(UR10E.joint_limits_rad, 0.1), 600, "random", seed=2)
    angle, height = facing(q, SIM_TRACKER_AT_MM)
    _, link = kinematics.chain(UR10E.mdh, q, all_frames=True)
    wrist = link[:, 4:, 2, 3].min(axis=1)
    cell = plans.CellConstraints(
        tracker_at_mm=SIM_TRACKER_AT_MM, acceptance_rad=0.6, floor_mm=100.0, flange2tool=TOOL
    )
    expected = (angle <= 0.6) & (height >= 100.0) & (wrist >= 100.0)
    assert 10 < expected.sum() < 300
    np.testing.assert_array_equal(plans.feasible(UR10E.mdh, q, cell), expected)
    no_floor = plans.CellConstraints(tracker_at_mm=SIM_TRACKER_AT_MM, acceptance_rad=0.6,
                                     floor_mm=None, flange2tool=TOOL)  # fmt: skip
    np.testing.assert_array_equal(plans.feasible(UR10E.mdh, q, no_floor), angle <= 0.6)
    only_floor = plans.CellConstraints(floor_mm=100.0, flange2tool=TOOL)
    np.testing.assert_array_equal(plans.feasible(UR10E.mdh, q, only_floor), expected | (
        (height >= 100.0) & (wrist >= 100.0)))  # fmt: skip
    assert plans.feasible(UR10E.mdh, q[0], only_floor).shape == (1,)


def test_default_cell_is_five_degrees_of_margin_thirty_of_acceptance_and_the_floor():
    cell = plans.CellConstraints()
    assert cell.margin_rad == pytest.approx(np.radians(5))
    assert cell.acceptance_rad == pytest.approx(np.radians(30))
    assert cell.floor_mm == 0.0 and cell.tracker_at_mm is None
    np.testing.assert_array_equal(cell.flange2tool, np.eye(4))


def test_d_optimal_selection_picks_distinct_poses_better_than_the_first_ones():
    q = plans.sample(plans.joint_box(UR10E.joint_limits_rad, 0.1), 200, "halton", seed=3)
    blocks = plans.observability(UR10E.mdh, q, TOOL).blocks
    picks = plans.select_d_optimal(blocks, 12)
    assert len(set(picks.tolist())) == 12
    assert plans.log_det(blocks[picks]) > plans.log_det(blocks[:12]) + 1.0
    # The first pick is the single pose that sees most: the largest det(I + J J^T / ridge).
    ridge = 1e-9 * np.sum(blocks**2) / len(blocks)
    single = [np.linalg.slogdet(np.eye(3) + b @ b.T / ridge)[1] for b in blocks]
    assert picks[0] == int(np.argmax(single))
    with pytest.raises(plans.PlanError, match="201 poses asked, only 200 candidates"):
        plans.select_d_optimal(blocks, 201)


def test_make_filters_then_selects_as_asked():
    cell = plans.CellConstraints(tracker_at_mm=SIM_TRACKER_AT_MM, flange2tool=TOOL)
    args = (UR10E.mdh, UR10E.joint_limits_rad)
    pool = plans.sample(plans.joint_box(args[1], cell.margin_rad), 2000, "halton", 4)
    feasible = pool[plans.feasible(UR10E.mdh, pool, cell)]
    np.testing.assert_array_equal(
        plans.make(*args, 5, cell, selection="first", seed=4), feasible[:5]
    )
    rand = plans.make(*args, 5, cell, selection="random", seed=4)
    assert all(any(np.array_equal(r, f) for f in feasible) for r in rand)
    assert not np.array_equal(rand, feasible[:5])
    d_opt = plans.make(*args, 5, cell, seed=4)
    blocks = plans.observability(UR10E.mdh, feasible, TOOL).blocks
    np.testing.assert_array_equal(d_opt, feasible[plans.select_d_optimal(blocks, 5)])
    with pytest.raises(plans.PlanError, match="unknown selection 'best'; use one of d-optimal, "):
        plans.make(*args, 5, cell, selection="best")


def test_make_from_given_candidates_drops_those_outside_the_box_or_the_cell():
    cell = plans.CellConstraints(tracker_at_mm=SIM_TRACKER_AT_MM, flange2tool=TOOL)
    args = (UR10E.mdh, UR10E.joint_limits_rad)
    good = plans.make(*args, 4, cell, selection="first")
    outside = good[:1].copy()
    outside[0, 1] = np.pi  # within the limits, not within the margin
    given = np.vstack([outside, good])
    np.testing.assert_array_equal(
        plans.make(*args, 4, cell, candidates=given, selection="first"), good
    )
    with pytest.raises(plans.PlanError, match="^only 4 candidate poses satisfy .*; 5 asked"):
        plans.make(*args, 5, cell, candidates=given, selection="first")
    few = plans.make(*args, 3, cell, n_candidates=100, selection="first")
    pool = plans.sample(plans.joint_box(args[1], cell.margin_rad), 100, "halton", 0)
    np.testing.assert_array_equal(few, pool[plans.feasible(UR10E.mdh, pool, cell)][:3])


# ---------------------------------------------------------------- the command


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
    made = plans.make_checked(UR10E, 12, cell, (5.0, 0.0, 90.0), margin_rad=np.radians(10),
                              n_candidates=3000, method="random", seed=3,
                              speed_rad_s=0.5, accel_rad_s2=1.0)  # fmt: skip
    written = plans.read_plan(tmp_path / "p.csv")
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
        + f", d-optimal selection, log det(J^T J) {plans.log_det(made.blocks):.2f}, "
        f"smallest singular value {plans.min_singular(made.blocks):.4g}"
    )


def test_plan_command_without_a_tracker_aims_at_the_simulated_cells_and_says_so(tmp_path):
    from calibrator import cell as cells
    from calibrator.simulate import SIM_TRACKER_AT_MM

    given = plans.sample(plans.joint_box(UR10E.joint_limits_rad, 0.1), 3000, "random", seed=8)
    plans.write_csv(tmp_path / "c.csv", given)
    done = cli("plan", "--from", "c.csv", "--poses", "9", "--selection", "first", cwd=tmp_path)
    assert done.code == 0, done.stderr
    assert "9 poses" in done.stdout and ", first selection, log det(J^T J) " in done.stdout
    assert "the poses face the simulated cell's tracker at 2500,400,300 mm" in done.stderr
    cell = cells.Cell(tracker_at_mm=tuple(SIM_TRACKER_AT_MM))
    expected = plans.make_checked(UR10E, 9, cell, (0.0, 0.0, 100.0), candidates=given,
                                  selection="first")  # fmt: skip
    written = plans.read_plan(tmp_path / "plan.csv")
    np.testing.assert_array_equal(written.path_rad, expected.plan.path_rad)
    assert written.origin.tracker_at_mm == (2500.0, 400.0, 300.0)


def test_plan_command_refuses_to_overwrite_its_candidates(tmp_path):
    plans.write_csv(tmp_path / "c.csv", np.zeros((3, 6)))
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
