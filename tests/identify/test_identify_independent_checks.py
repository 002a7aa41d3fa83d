"""Identification checked through what it returns, recomputed by an independent route.

Objectives and statistics are recomputed here from ``kinematics.forward``
(itself checked against a scipy chain in ``test_kinematics_independent``)
and scipy's rotations, never from the identifier's own helpers, so a result
that reports one thing and returns another is caught.
"""

import re

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from session_kit import simulated, written

from calibrator import robots, session
from calibrator.identify import pipeline, pso
from calibrator.model import kinematics
from calibrator.simulate import IPSO_PAPER_ERRORS, simulate

K = 1.0e4  # orientation weight used throughout (mm^2/rad^2)


def model_poses(result, q):
    """Tool poses (N, 4, 4) of the identified arm, straight from ``forward``."""
    return kinematics.forward(result.mdh, q, result.flange2tool, result.base2tracker)


def nominal_poses(result, q):
    mdh, base2tracker, flange2tool = result.space.unpack(np.zeros(result.space.size))
    np.testing.assert_array_equal(mdh, result.space.nominal_mdh)
    return kinematics.forward(mdh, q, flange2tool, base2tracker)


def rotation_errors(poses, obs):
    """Rotation vectors of model relative to measured orientation (N, 3), rad, via scipy."""
    rel = poses[:, :3, :3] @ np.swapaxes(obs.rotations, -1, -2)
    return Rotation.from_matrix(rel).as_rotvec()


def ssr(poses, obs, k):
    """The IPSO paper's objective: squared position errors plus k times squared turn angles."""
    total = np.sum((poses[:, :3, 3] - obs.points) ** 2)
    if k and obs.rotations is not None:
        total += k * np.sum(rotation_errors(poses, obs) ** 2)
    return total


def summary(values):
    return {"mean": np.mean(values), "std": np.std(values, ddof=1), "max": np.max(values)}


def assert_stats(reported, poses, obs):
    assert reported["n"] == len(obs)
    distance = np.linalg.norm(poses[:, :3, 3] - obs.points, axis=1)
    for key, value in summary(distance).items():
        assert reported["position_mm"][key] == pytest.approx(value, rel=1e-9, abs=1e-12), key
    if obs.rotations is not None:
        deg = np.degrees(np.abs(rotation_errors(poses, obs)))
        for i, axis in enumerate("xyz"):
            for key, value in summary(deg[:, i]).items():
                got = reported["orientation_deg"][axis][key]
                assert got == pytest.approx(value, rel=1e-6, abs=1e-9), (axis, key)


# --------------------------------------------------------------- the swarm's answer


def outside_the_box_session(tmp_path):
    """ER10L-C10 whose a2 is 5 mm off: outside the swarm's +-2 mm box on MDH lengths."""
    nominal = robots.get("er10l-c10").mdh
    truth = nominal + IPSO_PAPER_ERRORS
    truth[1, kinematics.A] += 5.0
    tool = np.eye(4)
    tool[:3, 3] = [0.0, 0.0, 100.0]
    q = np.random.default_rng(8).uniform(-2.5, 2.5, (30, 6))
    points = kinematics.forward(truth, q, tool)[:, :3, 3]
    meta = session.SessionMeta("base", nominal, "er10l-c10", tool, tool_known=True)
    return written(tmp_path, session.to_table(q, points), meta)


def test_swarm_answer_is_returned_inside_its_box_with_the_objective_it_reports(tmp_path):
    loaded = outside_the_box_session(tmp_path)
    options = pipeline.Options(method="pso", generations=150, validation_fraction=0, seed=2)
    result = pipeline.identify(loaded, options)
    lower, upper = result.space.bounds()
    assert np.all(result.x >= lower) and np.all(result.x <= upper)
    # The truth is out of reach, so the best particle sits on the wall of a2.
    a2 = result.space.free.index("a2")
    assert result.x[a2] == upper[a2]
    obs = loaded.observations
    at_result = ssr(model_poses(result, obs.q), obs, 0.0)
    at_nominal = ssr(nominal_poses(result, obs.q), obs, 0.0)
    assert result.details["pso"]["objective"] == pytest.approx(at_result, rel=1e-9)
    assert at_result < 0.05 * at_nominal  # the swarm's answer, not the nominal arm


def test_search_box_contains_the_true_frames_a_few_mm_from_their_first_guess(tmp_path):
    # Closed-form first guesses of the base frame and tool point are off by
    # up to a few mm (here 2-3.5 mm): the swarm's box must reach the truth.
    loaded, truth = simulated(
        tmp_path,
        "s.parquet",
        model="er10l-c10",
        poses=30,
        seed=5,
        frame="tracker",
        orientation=False,
        noise_mm=0.02,
        errors="random",
        tool_offset_mm=8.0,
    )
    result = pipeline.identify(loaded, pipeline.Options(method="lm", validation_fraction=0.2))
    true_deltas = result.space.pack(truth.mdh, truth.base2tracker, truth.flange2tool)
    frame = np.array([n.startswith(("base_", "tool_")) for n in result.space.free])
    assert np.max(np.abs(true_deltas[frame])) > 2.0  # the case this test is about
    lower, upper = result.space.bounds()
    assert np.all(true_deltas >= lower) and np.all(true_deltas <= upper)


def test_constriction_needs_phi_above_four():
    with pytest.raises(ValueError, match="exceed 4"):
        pso.constriction(2.0, 2.0)
    assert pso.constriction(2.5, 2.5) == pytest.approx(2 / abs(2 - 5 - np.sqrt(5)))


# ----------------------------------------------------------- held-out statistics


@pytest.fixture
def noisy(tmp_path):
    # Function scope on purpose: mutmut credits a fixture's calls to the first
    # test that uses it, so each test must run identify itself to be chosen.
    table, meta, _ = simulate(
        model="er10l-c10",
        poses=30,
        seed=11,
        frame="base",
        orientation=True,
        noise_mm=0.05,
        orientation_noise_rad=2e-4,
        errors="seed",
    )
    loaded = written(tmp_path, table, meta)
    options = pipeline.Options(method="hybrid", generations=100, k=K, seed=4)
    return tmp_path, table, meta, loaded, options, pipeline.identify(loaded, options)


def test_reported_statistics_are_those_of_the_poses_they_name(noisy):
    *_, loaded, _, result = noisy
    obs = loaded.observations
    assert len(result.validation_index) == 6
    assert not set(result.validation_index) & set(result.fit_index)
    assert sorted([*result.validation_index, *result.fit_index]) == list(range(30))
    for part, index in (("fit", result.fit_index), ("validation", result.validation_index)):
        sub = obs.subset(index)
        assert_stats(result.stats[part]["after"], model_poses(result, sub.q), sub)
        assert_stats(result.stats[part]["before"], nominal_poses(result, sub.q), sub)


def test_least_squares_objective_reported_is_the_sum_of_squared_residuals(noisy):
    *_, loaded, _, result = noisy
    fit = loaded.observations.subset(result.fit_index)
    expected = ssr(model_poses(result, fit.q), fit, K)
    assert result.details["least_squares"]["objective"] == pytest.approx(expected, rel=1e-9)
    # The swarm's objective uses the chordal form of the turn: equal to 4th order.
    assert result.details["pso"]["objective"] >= expected * (1 - 1e-6)


def test_corrupting_held_out_poses_leaves_the_fit_unchanged(noisy):
    tmp_path, table, meta, loaded, options, result = noisy
    bad = table.to_pandas()
    rows = bad["pose"].isin(result.validation_index)
    assert rows.sum() == 6
    bad.loc[rows, ["x_mm", "y_mm", "z_mm"]] += [3.0, -2.0, 4.0]
    corrupted = written(tmp_path, bad, meta, name="corrupted.parquet")
    again = pipeline.identify(corrupted, options)
    np.testing.assert_array_equal(again.validation_index, result.validation_index)
    np.testing.assert_array_equal(again.x, result.x)
    assert again.stats["fit"] == result.stats["fit"]
    # ... and the held-out error sees the corruption (about 5.4 mm).
    held_out = again.stats["validation"]["after"]["position_mm"]["mean"]
    assert held_out > 5.0 > result.stats["validation"]["after"]["position_mm"]["mean"]


# ------------------------------------------------------------- data-dependent pruning


def test_parameters_these_poses_cannot_separate_are_not_left_free(tmp_path):
    # Wrist joint 5 never moves: axes 4 and 6 stay aligned, and the data
    # cannot tell several wrist parameters apart, though the model can. (The
    # tool point is off axis 6: on it, theta4 would move nothing at q5 = 0.)
    nominal = robots.get("er10l-c10").mdh
    tool = np.eye(4)
    tool[:3, 3] = [30.0, 20.0, 100.0]
    q = np.random.default_rng(0).uniform(-2, 2, (30, 6))
    q[:, 4] = 0.0
    points = kinematics.forward(nominal + IPSO_PAPER_ERRORS, q, tool)[:, :3, 3]
    meta = session.SessionMeta("base", nominal, "er10l-c10", tool, tool_known=True)
    loaded = written(tmp_path, session.to_table(q, points), meta)
    result = pipeline.identify(loaded, pipeline.Options(method="lm", validation_fraction=0))
    # Every free parameter moves the measured points in its own direction:
    # the finite-difference Jacobian, columns scaled to unit length, has full rank.
    x, step = result.x, 1e-6
    columns = []
    for i in range(result.space.size):
        e = np.zeros_like(x)
        e[i] = step
        plus, minus = (_tool_points(result.space, x + s * e, q) for s in (1, -1))
        columns.append((plus - minus).ravel() / (2 * step))
    jac = np.column_stack(columns)
    jac /= np.linalg.norm(jac, axis=0)
    assert np.linalg.svd(jac, compute_uv=False)[-1] > 1e-4
    assert any(re.search(r"\bthese poses\b", d["reason"]) for d in result.dropped)


def _tool_points(space, x, q):
    mdh, base2tracker, flange2tool = space.unpack(x)
    return kinematics.forward(mdh, q, flange2tool, base2tracker)[:, :3, 3]


# --------------------------------------------------------------------- the swarm itself


class Recorder:
    """A bowl objective that remembers every swarm it was asked about."""

    def __init__(self, target):
        self.target, self.calls = np.asarray(target, float), []

    def __call__(self, x):
        self.calls.append(np.array(x))
        return np.sum((x - self.target) ** 2, axis=1)


def test_initial_swarm_fills_the_middle_of_the_box_and_the_best_is_returned():
    lower, upper = np.array([0.0, 10.0, -5.0]), np.array([2.0, 30.0, -1.0])
    bowl = Recorder([2.5, 0.0, -3.0])
    found = pso.ipso(bowl, lower, upper, particles=12, generations=0, init_fraction=0.25)
    assert len(bowl.calls) == 1 and bowl.calls[0].shape == (12, 3)
    start = bowl.calls[0]
    centre, half = (upper + lower) / 2, (upper - lower) / 2
    assert np.all(np.abs(start - centre) <= 0.25 * half)
    assert np.all(np.abs(start - centre).max(axis=0) > 0.1 * half)  # and spreads over it
    f0 = bowl(start)
    assert found.f == f0.min() and found.history.tolist() == [f0.min()]
    np.testing.assert_array_equal(found.x, start[np.argmin(f0)])


@pytest.mark.parametrize("quasi_random", [True, False])
def test_swarm_pinned_against_the_lower_wall_stays_on_it(quasi_random):
    lower, upper = np.array([-1.0, 0.0]), np.array([1.0, 4.0])
    bowl = Recorder([0.3, -2.0])  # second coordinate's optimum is below the box
    found = pso.ipso(bowl, lower, upper, generations=150, seed=3, quasi_random=quasi_random)
    assert len(bowl.calls) == 151 and found.history.shape == (151,)
    assert all(np.all((c >= lower) & (c <= upper)) for c in bowl.calls)
    assert np.all(np.ptp(bowl.calls[0], axis=0) > 0.1 * (upper - lower) / 2)  # a spread start
    assert found.x[1] == 0.0
    assert found.x[0] == pytest.approx(0.3, abs=1e-4)


def test_defaults_are_the_seeds_ipso():
    # 20 particles, 2000 generations, Halton start, seed 0: what identify relies on.
    bowl = Recorder(np.linspace(-0.5, 0.5, 4))
    lower, upper = -np.ones(4), np.ones(4)
    default = pso.ipso(bowl, lower, upper)
    assert len(bowl.calls) == 2001 and bowl.calls[0].shape == (20, 4)
    again = Recorder(bowl.target)
    explicit = pso.ipso(
        again,
        lower,
        upper,
        particles=20,
        generations=2000,
        seed=0,
        quasi_random=True,
    )
    np.testing.assert_array_equal(default.x, explicit.x)
    np.testing.assert_array_equal(bowl.calls[0], again.calls[0])  # the same Halton start


# ---------------------------------------------------------------- options and counts


def small_session(tmp_path, poses, orientation, frame="base", tool_offset_mm=0.0):
    loaded, _ = simulated(
        tmp_path,
        f"s{poses}{orientation}{frame}.parquet",
        model="er10l-c10",
        poses=poses,
        seed=6,
        frame=frame,
        orientation=orientation,
        errors="seed",
        tool_offset_mm=tool_offset_mm,
    )
    return loaded


def lm(**kwargs):
    return pipeline.Options(method="lm", validation_fraction=0, **kwargs)


def test_bad_options_are_refused_naming_them(tmp_path):
    loaded = small_session(tmp_path, 10, True)
    with pytest.raises(pipeline.IdentifiabilityError, match="method: 'newton' is not one of"):
        pipeline.identify(loaded, pipeline.Options(method="newton"))
    with pytest.raises(pipeline.IdentifiabilityError, match="k: must be a number >= 0, got -1"):
        pipeline.identify(loaded, lm(k=-1.0))
    with pytest.raises(pipeline.IdentifiabilityError, match=r"must be in \[0, 1\), got 1"):
        pipeline.identify(loaded, pipeline.Options(method="lm", validation_fraction=1.0))
    for k in (0.0, 0.5):  # zero and small weights are fine
        assert pipeline.identify(loaded, lm(k=k)).k == k


def test_fitting_pose_counts_are_checked_with_the_counts_in_the_message(tmp_path):
    two = small_session(tmp_path, 2, True)
    with pytest.raises(pipeline.IdentifiabilityError, match="2 fitting poses: at least 3"):
        pipeline.identify(two, lm())
    # 3 poses with orientation: 18 values for 24 parameters.
    with pytest.raises(
        pipeline.IdentifiabilityError, match="^18 measured values from .*3 fitting poses"
    ):
        pipeline.identify(small_session(tmp_path, 3, True), lm())
    # 6 poses without orientation: 18 values for the 21 parameters seen without it.
    with pytest.raises(
        pipeline.IdentifiabilityError, match="^18 measured values from .*6 fitting poses"
    ):
        pipeline.identify(small_session(tmp_path, 6, False), lm())
    # 4 poses with orientation: exactly 24 values, enough to try.
    assert pipeline.identify(small_session(tmp_path, 4, True), lm()).space.size > 0


def test_tool_option_overrides_the_session_and_reasons_name_their_scope(tmp_path):
    loaded = small_session(tmp_path, 30, False, frame="tracker", tool_offset_mm=5.0)
    assert not loaded.meta.tool_known
    free = pipeline.identify(loaded, lm()).space.free
    assert {"tool_x", "tool_y", "tool_z"} <= set(free)
    result = pipeline.identify(loaded, lm(tool_known=True))
    assert not {"tool_x", "tool_y", "tool_z"} & set(result.space.free)
    assert any(d["reason"].endswith("(for any poses)") for d in result.dropped)
    # Without orientation data the orientation weight plays no part.
    assert pipeline.identify(loaded, lm(k=5.0)).k == 0.0
