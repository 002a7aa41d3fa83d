"""Simulated sessions against what the simulator promises, checked from outside.

Points are re-computed with ``kinematics.forward`` from the truth written
beside the session, orientations with scipy's ``Rotation``, and the noise is
measured on many poses against the figures the docstrings give.
"""

import json

import numpy as np
import pyarrow.parquet as pq
import pytest
from cli_kit import cli, one_line_error
from scipy.spatial.transform import Rotation

from calibrator import robots, session
from calibrator import simulate as sim
from calibrator.model import kinematics

# The IPSO paper, Table 2 (a mm, alpha rad, theta rad, d mm, beta rad), typed again from the
# paper on purpose: an independent copy to hold calibrator.simulate's own against (importing
# it would make the test pass whatever the simulator's table says).
IPSO_TABLE_2 = [
    [-0.4751, 0.0058, 0.0091, -0.4221, 0.0],
    [0.2565, 0.0092, -0.0003, 0.0, -0.0028],
    [-0.3366, 0.0031, 0.0060, 0.3409, 0.0],
    [-0.1827, -0.0093, -0.0072, 0.1420, 0.0],
    [-0.1117, 0.0070, -0.0016, 0.1753, 0.0],
    [-0.2536, 0.0087, 0.0083, 0.1531, 0.0],
]


def columns(table, *names):
    return np.column_stack([table.column(n).to_numpy() for n in names])


def joints(table):
    return columns(table, *(f"q{i}_rad" for i in range(1, 7)))


def test_ref003_truth_is_table_2_of_the_seed_on_the_flange():
    table, meta, truth = sim.simulate(poses=5, orientation=False)
    np.testing.assert_allclose(truth.mdh - robots.get("er10l-c10").mdh, IPSO_TABLE_2, atol=1e-12)
    # The IPSO paper measures the flange itself: the tool is the identity and known.
    np.testing.assert_array_equal(truth.flange2tool, np.eye(4))
    np.testing.assert_array_equal(meta.flange2tool, np.eye(4))
    assert meta.tool_known is True
    assert meta.model == "er10l-c10" and meta.frame == "base"
    np.testing.assert_array_equal(meta.nominal_mdh, robots.get("er10l-c10").mdh)
    assert meta.extra["simulated"] == {
        "seed": 3,
        "noise_mm": 0.0,
        "orientation_noise_rad": 0.0,
        "joint_noise_rad": 0.0,
        "errors": "ref003",
    }
    assert "rx_rad" not in table.column_names and "sx_mm" not in table.column_names


def test_seed_is_the_old_name_of_ref003_and_bad_choices_are_refused():
    a = sim.simulate(poses=4, errors="seed")
    b = sim.simulate(poses=4, errors="ref003")
    assert a[1].extra["simulated"]["errors"] == "ref003"
    np.testing.assert_array_equal(a[2].mdh, b[2].mdh)
    with pytest.raises(ValueError) as info:
        sim.simulate(model="ur5e", poses=3)
    assert str(info.value) == (
        "the ref003 error table (paper 003, Table 2) is for er10l-c10; "
        "use random errors for other models"
    )
    with pytest.raises(ValueError, match="errors must be 'ref003', 'random' or 'none', got 'big'"):
        sim.simulate(poses=3, errors="big")
    with pytest.raises(ValueError, match="frame must be 'base' or 'tracker', got 'world'"):
        sim.simulate(poses=3, frame="world")


@pytest.mark.parametrize("frame", ["tracker", "base"])
def test_recorded_poses_are_the_true_arm_seen_in_the_recorded_frame(frame):
    table, meta, truth = sim.simulate(
        model="ur10e", poses=25, seed=8, frame=frame, errors="random", tool_offset_mm=0.0
    )
    assert meta.frame == frame
    q = joints(table)
    pose = kinematics.forward(truth.mdh, q, truth.flange2tool, truth.base2tracker)
    np.testing.assert_allclose(columns(table, "x_mm", "y_mm", "z_mm"), pose[:, :3, 3], atol=1e-9)
    rotvecs = columns(table, "rx_rad", "ry_rad", "rz_rad")
    np.testing.assert_allclose(
        Rotation.from_rotvec(rotvecs).as_matrix(), pose[:, :3, :3], atol=1e-12
    )
    # The default probe sits 100 mm along the flange's z axis and is known.
    np.testing.assert_allclose(truth.flange2tool[:3, 3], [0.0, 0.0, 100.0])
    np.testing.assert_array_equal(meta.flange2tool, truth.flange2tool)
    np.testing.assert_array_equal(table.column("n_readings").to_numpy(), np.full(25, 10))
    if frame == "base":
        np.testing.assert_array_equal(truth.base2tracker, np.eye(4))
    else:
        assert np.linalg.norm(truth.base2tracker[:3, 3]) > 1500.0


def test_the_tracker_stands_about_three_metres_away_turned_arbitrarily():
    offsets, angles, rotvecs = [], [], []
    for seed in range(40):
        truth = sim.simulate(poses=1, seed=seed, frame="tracker", errors="none")[2]
        offsets.append(truth.base2tracker[:3, 3])
        angles.append(Rotation.from_matrix(truth.base2tracker[:3, :3]).magnitude())
        rotvecs.append(Rotation.from_matrix(truth.base2tracker[:3, :3]).as_rotvec())
    offsets, angles = np.array(offsets), np.array(angles)
    assert np.all(np.ptp(rotvecs, axis=0) > 1.0)
    # x in 3 m +- 1 m, y and z within +-1 m, each spread over its whole range.
    assert np.all(np.abs(offsets - [3000.0, 0.0, 0.0]) <= 1000.0)
    assert np.all(np.ptp(offsets, axis=0) > 1000.0)
    # Rotation vectors uniform in +-pi/2 per axis: angles up to pi/2 * sqrt(3).
    assert angles.max() <= np.pi / 2 * np.sqrt(3) and angles.max() > 1.5
    assert np.all(np.abs(Rotation.from_matrix(truth.base2tracker[:3, :3]).as_rotvec()) <= np.pi / 2)


def test_an_unknown_tool_lies_the_offset_away_from_the_guess():
    _, meta, truth = sim.simulate(model="ur5e", poses=3, seed=4, errors="none", tool_offset_mm=7.5)
    assert meta.tool_known is False
    np.testing.assert_allclose(meta.flange2tool[:3, 3], [0.0, 0.0, 100.0])
    offset = truth.flange2tool[:3, 3] - meta.flange2tool[:3, 3]
    assert np.linalg.norm(offset) == pytest.approx(7.5, rel=1e-12)
    assert np.all(offset != 0)
    np.testing.assert_array_equal(truth.flange2tool[:3, :3], np.eye(3))
    # On the IPSO paper's arm the guess is the default probe too, not the flange.
    _, meta, truth = sim.simulate(poses=3, tool_offset_mm=2.0)
    np.testing.assert_allclose(meta.flange2tool[:3, 3], [0.0, 0.0, 100.0])
    assert np.linalg.norm(truth.flange2tool[:3, 3] - [0, 0, 100]) == pytest.approx(2.0)


def test_no_errors_is_the_nominal_arm_and_32_poses_the_default():
    table, _, truth = sim.simulate(model="ur10", errors="none")
    assert table.num_rows == 32
    np.testing.assert_array_equal(truth.mdh, robots.get("ur10").mdh)


def test_point_noise_has_the_rms_asked_for_and_spreads_of_single_readings():
    table, _, truth = sim.simulate(
        model="ur5e", poses=3000, seed=1, frame="tracker", errors="none", noise_mm=3.0
    )
    q = joints(table)
    exact = kinematics.forward(truth.mdh, q, truth.flange2tool, truth.base2tracker)[:, :3, 3]
    error = columns(table, "x_mm", "y_mm", "z_mm") - exact
    rms_3d = np.sqrt(np.mean(np.sum(error**2, axis=1)))
    assert rms_3d == pytest.approx(3.0, rel=0.04)
    assert np.abs(error.mean(axis=0)).max() < 0.2
    # One reading has sqrt(10) times the averaged point's per-axis error; the
    # spreads are sample standard deviations (ddof=1), so their squares average
    # to its variance. (At 3 mm the 6 um/m range term is negligible.)
    spread = columns(table, "sx_mm", "sy_mm", "sz_mm")
    per_reading = 3.0 / np.sqrt(3) * np.sqrt(10)
    assert np.mean(spread**2) == pytest.approx(per_reading**2, rel=0.03)


def test_spreads_in_the_base_frame_are_turned_and_positive():
    table, _, _ = sim.simulate(poses=400, seed=2, frame="base", noise_mm=0.3)
    spread = columns(table, "sx_mm", "sy_mm", "sz_mm")
    assert np.all(spread > 0)
    per_reading = 0.3 / np.sqrt(3) * np.sqrt(10)
    assert np.mean(np.linalg.norm(spread, axis=1)) == pytest.approx(
        per_reading * np.sqrt(3), rel=0.15
    )


def test_orientation_noise_has_the_rms_angle_asked_for():
    table, _, truth = sim.simulate(
        model="ur5e", poses=3000, seed=5, frame="tracker", errors="none", orientation_noise_rad=2e-3
    )
    exact = kinematics.forward(truth.mdh, joints(table), truth.flange2tool, truth.base2tracker)
    recorded = Rotation.from_rotvec(columns(table, "rx_rad", "ry_rad", "rz_rad"))
    # The tilt is applied in the tracker frame: recorded = tilt . true.
    tilt = recorded * Rotation.from_matrix(exact[:, :3, :3]).inv()
    assert np.sqrt(np.mean(tilt.magnitude() ** 2)) == pytest.approx(2e-3, rel=0.04)
    assert np.abs(tilt.as_rotvec().mean(axis=0)).max() < 1e-4


def test_joint_noise_changes_the_read_angles_not_the_measured_points():
    kwargs = dict(model="ur5e", poses=2000, seed=6, errors="none")
    clean, _, _ = sim.simulate(**kwargs)
    noisy, _, _ = sim.simulate(**kwargs, joint_noise_rad=1e-3)
    dq = joints(noisy) - joints(clean)
    assert dq.std() == pytest.approx(1e-3, rel=0.03)
    assert abs(dq.mean()) < 1e-4
    np.testing.assert_array_equal(
        columns(noisy, "x_mm", "y_mm", "z_mm"), columns(clean, "x_mm", "y_mm", "z_mm")
    )


def test_joints_are_drawn_uniformly_within_the_limits_and_one_turn():
    rng = np.random.default_rng(0)
    limits = np.array([[-2, 2], [-2, 2], [-1, 1], [-0.5, 0.25], [-2, 2], [0.1, 0.2]]) * np.pi
    q = sim.sample_joints(limits, 20000, rng)
    assert q.shape == (20000, 6)
    lo = np.maximum(limits[:, 0], -np.pi)
    hi = np.minimum(limits[:, 1], np.pi)
    assert np.all(q >= lo) and np.all(q <= hi)
    assert np.all(np.abs(q.min(axis=0) - lo) < 0.01 * (hi - lo))
    assert np.all(np.abs(q.max(axis=0) - hi) < 0.01 * (hi - lo))
    assert np.all(np.abs(q.mean(axis=0) - (lo + hi) / 2) < 0.02 * (hi - lo))


def test_tracker_noise_is_wider_across_the_beam_by_range():
    rng = np.random.default_rng(1)
    # Points 10 m out along x: along the beam sigma; across it sigma + 3 um/m * 10 m.
    points = np.tile([10_000.0, 0.0, 0.0], (20, 1))
    readings = sim.tracker_readings(points, 2000, 0.01, rng)
    assert readings.shape == (20, 2000, 3)
    dev = (readings - points[:, None]).reshape(-1, 3)
    assert dev[:, 0].std() == pytest.approx(0.01, rel=0.03)
    assert dev[:, 1].std() == pytest.approx(0.04, rel=0.03)
    assert dev[:, 2].std() == pytest.approx(0.04, rel=0.03)
    # Along another direction the same holds in the beam's own axes.
    beam = np.array([0.0, 0.6, 0.8])
    readings = sim.tracker_readings(np.tile(5000.0 * beam, (20, 1)), 2000, 0.02, rng)
    dev = (readings - 5000.0 * beam).reshape(-1, 3)
    along = dev @ beam
    assert along.std() == pytest.approx(0.02, rel=0.03)
    assert (dev - along[:, None] * beam)[:, 0].std() == pytest.approx(0.035, rel=0.03)


def test_a_noiseless_tracker_reads_the_points_exactly_even_at_its_origin():
    points = np.array([[0.0, 0.0, 0.0], [1200.0, -5.0, 3.0]])
    readings = sim.tracker_readings(points, 4, 0.0, np.random.default_rng(2))
    np.testing.assert_array_equal(readings, np.broadcast_to(points[:, None], (2, 4, 3)))


def test_random_errors_touch_only_identifiable_parameters_within_their_size():
    nominal = robots.get("er10l-c10").mdh
    draws = np.array([sim.random_errors(nominal, np.random.default_rng(s)) for s in range(60)])
    # ER10L-C10: axes 2 and 3 are parallel, so d2 is replaced by beta2 (Hayati);
    # no other beta is a parameter.
    zero = np.zeros((6, 5), bool)
    zero[1, kinematics.D] = True
    zero[[0, 2, 3, 4, 5], kinematics.BETA] = True
    assert np.all(draws[:, zero] == 0)
    free = draws[:, ~zero]
    assert np.all(free != 0)
    lengths = draws[..., [kinematics.A, kinematics.D]][:, ~zero[:, [kinematics.A, kinematics.D]]]
    angles = draws[..., [kinematics.ALPHA, kinematics.THETA, kinematics.BETA]][
        :, ~zero[:, [kinematics.ALPHA, kinematics.THETA, kinematics.BETA]]
    ]
    assert np.abs(lengths).max() <= 0.5 and np.abs(lengths).max() > 0.45
    assert np.abs(angles).max() <= 0.01 and np.abs(angles).max() > 0.009
    # Uniform in +-size: both signs, about as often, and every entry its own draw.
    assert 0.4 < np.mean(free > 0) < 0.6
    assert len(np.unique(free)) == free.size
    small = sim.random_errors(nominal, np.random.default_rng(0), mm=0.1, rad=0.001)
    assert np.abs(small[:, [0, 3]]).max() <= 0.1 and np.abs(small[:, [1, 2, 4]]).max() <= 0.001


def test_truth_json_holds_the_three_arrays_as_lists():
    truth = sim.Truth(np.arange(30.0).reshape(6, 5), np.eye(4) * 2, np.eye(4) * 3)
    doc = json.loads(json.dumps(truth.to_json()))
    assert sorted(doc) == ["base2tracker", "flange2tool", "mdh"]
    np.testing.assert_array_equal(doc["mdh"], np.arange(30.0).reshape(6, 5))
    np.testing.assert_array_equal(doc["base2tracker"], np.eye(4) * 2)
    np.testing.assert_array_equal(doc["flange2tool"], np.eye(4) * 3)


def test_cli_writes_the_session_and_its_truth(tmp_path):
    done = cli(
        "simulate", "-o", "s.parquet", "--model", "ur5e", "--poses", "6", "--seed", "9",
        "--frame", "tracker", "--noise-mm", "0", "--orientation-noise-deg", "0",
        "--tool-offset-mm", "4", cwd=tmp_path,
    )  # fmt: skip
    assert done.code == 0, done.stderr
    assert done.stdout.strip() == (
        "wrote s.parquet (6 poses, model ur5e, frame tracker) and s.truth.json"
    )
    loaded = session.load(tmp_path / "s.parquet")
    truth = json.loads((tmp_path / "s.truth.json").read_text())
    assert loaded.meta.model == "ur5e" and loaded.meta.frame == "tracker"
    assert loaded.meta.tool_known is False
    assert loaded.meta.extra["simulated"]["errors"] == "random"
    assert loaded.meta.extra["simulated"]["seed"] == 9
    obs = loaded.observations
    pose = kinematics.forward(truth["mdh"], obs.q, truth["flange2tool"], truth["base2tracker"])
    np.testing.assert_allclose(obs.points, pose[:, :3, 3], atol=1e-9)
    np.testing.assert_allclose(
        np.linalg.norm(np.array(truth["flange2tool"])[:3, 3] - [0, 0, 100]), 4.0
    )
    # The same command with the same seed gives the same session.
    again = cli(
        "simulate", "-o", "t.parquet", "--model", "ur5e", "--poses", "6", "--seed", "9",
        "--frame", "tracker", "--noise-mm", "0", "--orientation-noise-deg", "0",
        "--tool-offset-mm", "4", cwd=tmp_path,
    )  # fmt: skip
    assert again.code == 0
    assert pq.read_table(tmp_path / "t.parquet").equals(pq.read_table(tmp_path / "s.parquet"))


def test_cli_defaults_are_the_seeds_arm_with_small_noise(tmp_path):
    done = cli("simulate", "-o", "d.parquet", "--poses", "1", cwd=tmp_path)
    assert done.code == 0, done.stderr
    assert (
        done.stdout.strip()
        == "wrote d.parquet (1 pose, model er10l-c10, frame base) and d.truth.json"
    )
    meta = json.loads(pq.read_schema(tmp_path / "d.parquet").metadata[b"calibrator"])
    simulated = meta["simulated"]
    assert simulated["errors"] == "ref003" and simulated["seed"] == 3
    assert simulated["noise_mm"] == 0.02 and simulated["joint_noise_rad"] == 0.0
    assert simulated["orientation_noise_rad"] == pytest.approx(np.radians(0.005), rel=1e-12)
    table = pq.read_table(tmp_path / "d.parquet")
    assert "rx_rad" in table.column_names and "sx_mm" in table.column_names


def test_cli_random_errors_are_the_default_off_the_seeds_arm(tmp_path):
    done = cli("simulate", "-o", "u.parquet", "--model", "UR10", "--poses", "2", cwd=tmp_path)
    assert done.code == 0, done.stderr
    meta = json.loads(pq.read_schema(tmp_path / "u.parquet").metadata[b"calibrator"])
    assert meta["simulated"]["errors"] == "random" and meta["model"] == "ur10"
    old_name = cli("simulate", "-o", "s.parquet", "--poses", "2", "--errors", "seed", cwd=tmp_path)
    assert old_name.code == 0, old_name.stderr
    meta = json.loads(pq.read_schema(tmp_path / "s.parquet").metadata[b"calibrator"])
    assert meta["simulated"]["errors"] == "ref003"
    truth = json.loads((tmp_path / "s.truth.json").read_text())
    np.testing.assert_allclose(
        np.array(truth["mdh"]) - robots.get("er10l-c10").mdh, IPSO_TABLE_2, atol=1e-12
    )
    line = one_line_error(cli("simulate", "--errors", "tiny", cwd=tmp_path))
    assert "must be one of ref003, random, none, got 'tiny'" in line
    assert "ref003 error table" in one_line_error(
        cli("simulate", "--model", "ur10e", "--errors", "ref003", cwd=tmp_path)
    )
