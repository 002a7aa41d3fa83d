"""The minimax refinement on a problem whose answer is known: the smallest enclosing ball.

With only the base frame's translation ``t`` free, pose j's error is
``|t - d_j|`` for the offset ``d_j`` of its measured point from the nominal
one, so the minimax answer is the centre of the smallest ball holding every
``d_j`` and the worst error is that ball's radius.
"""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from calibrator import robots
from calibrator.identify import minimax
from calibrator.identify.problem import Problem
from calibrator.model import kinematics, measurement, parameters, rotations

K = 1.0e4
TRANSLATION = ("base_tx", "base_ty", "base_tz")


def ball_problem(offsets, seed=0):
    """Observations whose points are the nominal ones plus ``offsets`` (N, 3)."""
    offsets = np.asarray(offsets, dtype=float)
    space = parameters.ParameterSpace(robots.get("er10l-c10").mdh, free=TRANSLATION)
    q = np.random.default_rng(seed).uniform(-2, 2, (len(offsets), 6))
    nominal = measurement.predict(space, np.zeros(3), q)[:, :3, 3]
    return space, measurement.Observations(q, nominal + offsets)


# Smallest enclosing ball: centre (1, 0, 0), radius 2, fixed by the first two.
OFFSETS = [[-1, 0, 0], [3, 0, 0], [1, 1, 0], [1, -1.5, 0], [1, 0, 1], [0.5, 0.5, -0.5]]


def test_pose_errors_are_squared_distance_plus_k_squared_turn():
    robot = robots.get("er10l-c10")
    space = parameters.ParameterSpace(robot.mdh, free=("a2", "theta3", "tool_rx"))
    rng = np.random.default_rng(1)
    q = rng.uniform(-2, 2, (4, 6))
    x = np.array([0.3, 0.002, -0.004])
    pose = kinematics.forward(robot.mdh, q)
    obs = measurement.Observations(
        q,
        pose[:, :3, 3] + rng.normal(0, 0.1, (4, 3)),
        rotations.rotvec_to_matrix(rng.normal(0, 1e-3, (4, 3))) @ pose[:, :3, :3],
    )
    mdh = robot.mdh.copy()
    mdh[1, kinematics.A] += 0.3
    mdh[2, kinematics.THETA] += 0.002
    tool = np.eye(4)
    tool[:3, :3] = rotations.rotations_xyz([-0.004, 0, 0])
    model = kinematics.forward(mdh, q, tool)
    dp = np.sum((model[:, :3, 3] - obs.points) ** 2, axis=1)
    turn = Rotation.from_matrix(model[:, :3, :3] @ np.swapaxes(obs.rotations, 1, 2)).as_rotvec()
    expected = dp + K * np.sum(turn**2, axis=1)
    np.testing.assert_allclose(Problem.of(space, obs, K).pose_errors(x), expected, rtol=1e-9)
    np.testing.assert_allclose(Problem.of(space, obs, 0.0).pose_errors(x), dp, rtol=1e-9)


@pytest.mark.parametrize("k", [0.0, K])
def test_pose_error_gradient_matches_finite_differences(k):
    robot = robots.get("er10l-c10")
    space = parameters.ParameterSpace(
        robot.mdh, free=("a2", "alpha2", "theta4", "base_tx", "tool_ry")
    )
    rng = np.random.default_rng(2)
    q = rng.uniform(-2, 2, (5, 6))
    pose = kinematics.forward(robot.mdh, q)
    obs = measurement.Observations(
        q,
        pose[:, :3, 3] + rng.normal(0, 0.5, (5, 3)),
        rotations.rotvec_to_matrix(rng.normal(0, 3e-3, (5, 3))) @ pose[:, :3, :3],
    )
    x = rng.normal(0, 1e-3, 5)
    e, grad = minimax._pose_error_jacobian(Problem.of(space, obs, k), x)
    np.testing.assert_allclose(e, Problem.of(space, obs, k).pose_errors(x), rtol=1e-12)
    assert grad.shape == (5, 5)
    for i in range(5):
        h = np.zeros(5)
        h[i] = 1e-6
        fd = Problem.of(space, obs, k).pose_errors(x + h) - Problem.of(space, obs, k).pose_errors(
            x - h
        )
        np.testing.assert_allclose(grad[:, i], fd / 2e-6, rtol=1e-4, atol=1e-6)


def test_minimax_finds_the_centre_of_the_smallest_enclosing_ball():
    space, obs = ball_problem(OFFSETS)
    start = np.mean(OFFSETS, axis=0)  # the least-squares answer
    out = minimax.refine_minimax(Problem.of(space, obs, 0.0), start)
    np.testing.assert_allclose(out.x, [1.0, 0.0, 0.0], atol=1e-5)
    assert out.info["worst_mm"] == pytest.approx(2.0, abs=1e-11)
    # The worst it reports is the worst over all poses at the point it returns.
    distance = np.linalg.norm(
        measurement.predict(space, out.x, obs.q)[:, :3, 3] - obs.points, axis=1
    )
    assert out.info["worst_mm"] == pytest.approx(distance.max(), rel=1e-12)
    start_worst = np.linalg.norm(start - np.asarray(OFFSETS), axis=1).max()
    assert out.info["worst_mm"] < start_worst - 0.05
    assert out.info["iterations"] > 0
    assert "successfully" in out.message or "Optimization terminated" in out.message


def test_minimax_from_the_answer_is_never_worse():
    space, obs = ball_problem(OFFSETS)
    out = minimax.refine_minimax(Problem.of(space, obs, 0.0), [1.0, 0.0, 0.0])
    assert out.info["worst_mm"] <= 2.0 + 1e-12


def test_minimax_with_a_round_cap_keeps_the_best_point_seen():
    space, obs = ball_problem(OFFSETS)
    start = np.array([0.0, 3.0, 0.0])
    start_worst = np.linalg.norm(start - np.asarray(OFFSETS), axis=1).max()
    out = minimax.refine_minimax(Problem.of(space, obs, 0.0), start, rounds=1, max_iterations=2)
    assert out.info["iterations"] <= 2
    distance = np.linalg.norm(
        measurement.predict(space, out.x, obs.q)[:, :3, 3] - obs.points, axis=1
    )
    assert out.info["worst_mm"] == pytest.approx(distance.max(), rel=1e-12)
    assert out.info["worst_mm"] < start_worst - 1.0  # two iterations go a long way ...
    assert out.info["worst_mm"] > 2.0 + 1e-3  # ... but do not reach the answer
    full = minimax.refine_minimax(Problem.of(space, obs, 0.0), start, rounds=1)
    assert full.info["worst_mm"] == pytest.approx(2.0, abs=1e-6)
    assert full.info["iterations"] > 2


def many_offsets(n=40, seed=3):
    """Offsets inside the ball of radius 2 about (1, 0, 0), the two ends of a diameter on it."""
    rng = np.random.default_rng(seed)
    inner = rng.normal(size=(n - 2, 3))
    inner *= (rng.uniform(0, 1.6, n - 2) / np.linalg.norm(inner, axis=1))[:, None]
    surface = np.array([[-1, 0, 0], [3, 0, 0]], dtype=float)
    return np.vstack([inner + [1, 0, 0], surface])


def test_beyond_all_poses_the_active_set_grows_until_every_pose_is_judged(monkeypatch):
    # Surface points A (-1, 0, 0), B (3, 0, 0) and C (1, 2.2, 0), just outside A-B's
    # ball: the answer is their circumcircle, centre (1, 0.84 / 4.4, 0), radius
    # 2.2 - 0.84 / 4.4. Started at (1, 3.5, 0), C is not among the worst poses
    # at first; the ball of the others misses it by only 10 %.
    rng = np.random.default_rng(3)
    inner = rng.normal(size=(37, 3))
    inner *= (rng.uniform(0, 1.6, 37) / np.linalg.norm(inner, axis=1))[:, None]
    offsets = np.vstack([inner + [1, 0, 0], [[-1, 0, 0], [3, 0, 0], [1, 2.2, 0]]])
    space, obs = ball_problem(offsets, seed=4)
    start = np.array([1.0, 3.5, 0.0])
    e0 = np.sum((start - offsets) ** 2, axis=1)
    assert e0[-1] < 0.25 * e0.max()  # the case this test is about
    monkeypatch.setattr(minimax, "ALL_POSES", 10)
    out = minimax.refine_minimax(Problem.of(space, obs, 0.0), start)
    y = 0.84 / 4.4
    np.testing.assert_allclose(out.x, [1.0, y, 0.0], atol=1e-6)
    assert out.info["worst_mm"] == pytest.approx(2.2 - y, abs=1e-11)
    distance = np.linalg.norm(out.x - offsets, axis=1)
    assert out.info["worst_mm"] == pytest.approx(distance.max(), rel=1e-6)
    # Iterations add up over the rounds.
    first = minimax.refine_minimax(Problem.of(space, obs, 0.0), start, rounds=1)
    assert out.info["iterations"] > first.info["iterations"]


def test_active_fraction_picks_the_poses_near_the_worst(monkeypatch):
    # One round on the first active set only: with every pose active the answer
    # is the true centre; with the poses at >= 25 % of the worst squared error,
    # the round fits those alone and its answer need not hold for the rest.
    offsets = many_offsets()
    space, obs = ball_problem(offsets, seed=4)
    start = np.array([-0.5, 0.0, 0.0])
    e0 = np.sum((start - offsets) ** 2, axis=1)
    monkeypatch.setattr(minimax, "ALL_POSES", 10)
    one = minimax.refine_minimax(Problem.of(space, obs, 0.0), start, rounds=1)
    distance = np.linalg.norm(one.x - offsets, axis=1)
    assert one.info["worst_mm"] == pytest.approx(distance.max(), rel=1e-6)
    assert one.info["worst_mm"] <= np.sqrt(e0.max())
    assert one.info["worst_mm"] > 2.0 + 1e-3
    monkeypatch.setattr(minimax, "ACTIVE_FRACTION", 0.0)
    every = minimax.refine_minimax(Problem.of(space, obs, 0.0), start, rounds=1)
    assert every.info["worst_mm"] == pytest.approx(2.0, abs=1e-5)
    monkeypatch.setattr(minimax, "ALL_POSES", 500)
    monkeypatch.setattr(minimax, "ACTIVE_FRACTION", 2.0)  # unused up to ALL_POSES
    every = minimax.refine_minimax(Problem.of(space, obs, 0.0), start, rounds=1)
    assert every.info["worst_mm"] == pytest.approx(2.0, abs=1e-5)


def test_at_exactly_all_poses_every_pose_is_a_constraint_from_the_start(monkeypatch):
    offsets = many_offsets()
    space, obs = ball_problem(offsets, seed=4)
    monkeypatch.setattr(minimax, "ALL_POSES", len(offsets))
    one = minimax.refine_minimax(Problem.of(space, obs, 0.0), np.array([-0.5, 0.0, 0.0]), rounds=1)
    assert one.info["worst_mm"] == pytest.approx(2.0, abs=1e-5)


def test_minimax_with_orientation_lowers_the_worst_pose_below_least_squares():
    from calibrator.identify import refine

    robot = robots.get("er10l-c10")
    space = parameters.ParameterSpace(robot.mdh, free=("a2", "alpha2", "theta3", "d4"))
    rng = np.random.default_rng(6)
    q = rng.uniform(-2, 2, (12, 6))
    pose = measurement.predict(space, np.array([0.2, 0.003, -0.002, 0.3]), q)
    obs = measurement.Observations(
        q,
        pose[:, :3, 3] + rng.normal(0, 0.05, (12, 3)),
        rotations.rotvec_to_matrix(rng.normal(0, 2e-4, (12, 3))) @ pose[:, :3, :3],
    )
    start = refine.refine(Problem.of(space, obs, K), np.zeros(4)).x

    def per_pose(x):  # |dp|^2 + k |delta|^2, via scipy's rotation vectors
        model = measurement.predict(space, x, obs.q)
        turn = Rotation.from_matrix(model[:, :3, :3] @ np.swapaxes(obs.rotations, 1, 2)).as_rotvec()
        return np.sum((model[:, :3, 3] - obs.points) ** 2, axis=1) + K * np.sum(turn**2, axis=1)

    out = minimax.refine_minimax(Problem.of(space, obs, K), start)
    e = per_pose(out.x)
    assert out.info["worst_mm"] == pytest.approx(np.sqrt(e.max()), rel=1e-9)
    assert out.info["worst_mm"] < 0.95 * np.sqrt(per_pose(start).max())
    # At a minimax optimum several poses share the worst error.
    assert np.sum(e > e.max() * (1 - 1e-5)) >= 3
