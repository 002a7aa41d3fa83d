"""The identify pipeline's own decisions, on small sessions fitted by least squares.

What is checked is recomputed here: the split's sizes and seeding, the
refusals' exact messages, the pose numbers of outliers (from the session's
own ``pose`` column), the noise warning against the residuals, and the
minimax worst error against the distances of the returned arm.
"""

import identify_kit as arms
import numpy as np
import pyarrow as pa
import pytest
from scipy.spatial.transform import Rotation

from calibrator import robots, session
from calibrator.errors import IdentifiabilityError
from calibrator.identify import freeset, pipeline
from calibrator.model import kinematics, measurement, parameters


def small(n=16, noise_mm=0.0, orientation=False, numbers=None, bad=None, seed=0):
    """A session of ``n`` poses of a slightly wrong ER10L-C10, tool known.

    ``numbers``: the pose numbers stored in the table; ``bad``: index of a pose
    whose point is moved 3 mm.
    """
    robot = robots.get("er10l-c10")
    true = robot.mdh.copy()  # errors the fit can take up exactly
    true[1, kinematics.A] += 0.3
    true[2, kinematics.ALPHA] -= 0.002
    true[3, kinematics.THETA] += 0.003
    true[3, kinematics.D] -= 0.4
    q = arms.joints(robot, n, seed=seed + 1)
    tool = np.eye(4)
    tool[:3, 3] = [20.0, -10.0, 150.0]
    pose = arms.measure(true, q, tool)
    if bad is not None:
        pose[bad, :3, 3] += [2.0, -2.0, 1.0]
    data = arms.loaded(
        robot,
        q,
        pose,
        orientation=orientation,
        noise_mm=noise_mm,
        seed=seed,
        tool_guess=tool,
        tool_known=True,
    )
    if numbers is not None:
        table = data.table.set_column(0, "pose", pa.array(numbers, pa.int64()))
        data = session.Session(table, data.meta)
    return data


def lm(**kwargs):
    kwargs.setdefault("validation_fraction", 0.0)
    return pipeline.Options(method="lm", **kwargs)


# ------------------------------------------------------------------ split


@pytest.mark.parametrize(
    ("n", "fraction", "n_val"),
    [(10, 0.0, 0), (10, 0.25, 2), (10, 0.35, 4), (7, 0.5, 4), (3, 0.9, 3)],
)
def test_split_holds_out_the_rounded_share_sorted_and_disjoint(n, fraction, n_val):
    fit, val = pipeline.split(n, fraction, 5)
    assert len(val) == n_val
    assert sorted(np.r_[fit, val].tolist()) == list(range(n))
    assert fit.tolist() == sorted(fit.tolist()) and val.tolist() == sorted(val.tolist())
    again = pipeline.split(n, fraction, 5)
    assert fit.tolist() == again[0].tolist()


def test_split_is_seeded():
    draws = {tuple(pipeline.split(20, 0.3, seed)[1]) for seed in range(6)}
    assert len(draws) > 3
    order = np.random.default_rng(9).permutation(20)
    assert pipeline.split(20, 0.3, 9)[1].tolist() == sorted(order[:6].tolist())


@pytest.mark.parametrize("fraction", [-0.01, 1.0, 1.5])
def test_split_refuses_a_fraction_outside_zero_to_one(fraction):
    with pytest.raises(IdentifiabilityError) as err:
        pipeline.split(10, fraction, 0)
    assert str(err.value) == f"validation fraction must be in [0, 1), got {fraction}"


# ------------------------------------------------------------------ options


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (
            pipeline.Options(loss="l1"),
            "loss: 'l1' is not one of 'lsq', 'huber', 'trimmed', 'minimax'",
        ),
        (
            pipeline.Options(method="bfgs"),
            "method: 'bfgs' is not one of 'hybrid', 'pso', 'lm'",
        ),
        (pipeline.Options(k=float("nan")), "k: must be a finite number, got nan"),
        (pipeline.Options(k=-0.001), "k: must be a number >= 0, got -0.001"),
        (pipeline.Options(noise_mm=0.0), "noise_mm: must be a number >= 1e-09, got 0"),
        (pipeline.Options(noise_mm=float("nan")), "noise_mm: must be a finite number, got nan"),
        (pipeline.Options(swarm_poses=0), "swarm_poses: must be a whole number >= 1, got 0"),
    ],
)
def test_bad_options_are_refused_with_their_message(options, message):
    with pytest.raises(IdentifiabilityError) as err:
        pipeline._check_options(options)
    assert str(err.value) == message


def test_edge_options_are_accepted():
    pipeline._check_options(pipeline.Options(k=0.0, noise_mm=1e-9, swarm_poses=1))
    for loss in pipeline.LOSSES:
        for method in pipeline.METHODS:
            pipeline._check_options(pipeline.Options(loss=loss, method=method))


def test_defaults():
    o = pipeline.Options()
    assert (o.method, o.loss, o.k, o.validation_fraction, o.seed) == ("hybrid", "lsq", None, 0.2, 0)
    assert (o.particles, o.generations, o.noise_mm, o.swarm_poses) == (20, 2000, 0.05, 32)
    assert o.tool_known is None


# ------------------------------------------------------------------ helpers


def test_pose_numbers_come_from_the_pose_column_or_count_from_zero():
    data = small(n=5, numbers=[10, 11, 15, 20, 21])
    assert pipeline._pose_numbers(data, 5).tolist() == [10, 11, 15, 20, 21]
    bare = session.Session(data.table.drop_columns(["pose"]), data.meta)
    assert pipeline._pose_numbers(bare, 5).tolist() == [0, 1, 2, 3, 4]

    class NoTable:
        pass

    assert pipeline._pose_numbers(NoTable(), 3).tolist() == [0, 1, 2]


def test_names_lists_up_to_eight_then_counts_the_rest():
    assert pipeline._names(np.arange(8)) == "0, 1, 2, 3, 4, 5, 6, 7"
    assert pipeline._names(np.arange(10, 21)) == "10, 11, 12, 13, 14, 15, 16, 17 and 3 more"
    assert pipeline._names(np.arange(3), limit=2) == "0, 1 and 1 more"


@pytest.mark.parametrize("orientation", [False, True])
def test_generic_poses_are_the_nominal_arm_at_spread_joints(orientation):
    robot = robots.get("er10l-c10")
    tool = np.eye(4)
    tool[:3, 3] = [0.0, 0.0, 100.0]
    space = parameters.ParameterSpace(robot.mdh, np.eye(4), tool, ("a1",))
    generic = freeset.generic_poses(space, orientation)
    q, points, rot = generic.q, generic.points, generic.rotations
    assert q.shape == (64, 6) and np.abs(q).max() <= np.pi
    assert q.std(axis=0).min() > 1.5  # spread over the whole turn
    pose = kinematics.forward(robot.mdh, q, tool)
    np.testing.assert_allclose(points, pose[:, :3, 3], atol=1e-9)
    if orientation:
        np.testing.assert_allclose(rot, pose[:, :3, :3], atol=1e-12)
    else:
        assert rot is None


# ------------------------------------------------------------------ refusals


def test_a_session_above_the_pose_limit_is_refused(monkeypatch):
    monkeypatch.setattr(pipeline, "MAX_POSES", 7)
    with pytest.raises(IdentifiabilityError) as err:
        pipeline.identify(small(n=8), lm())
    assert str(err.value) == (
        "the session has 8 poses; identify takes at most 7 (thin it, e.g. keep every n-th "
        "pose: a well-spread subset identifies as well)"
    )


def test_too_few_distinct_fitting_poses_are_refused():
    data = small(n=6)
    q = data.observations.q
    table = data.table
    for col, name in enumerate(session.JOINT_COLUMNS):
        values = q[:, col].copy()
        values[2:] = values[1]  # poses 1..5 the same joints
        table = table.set_column(table.column_names.index(name), name, pa.array(values))
    with pytest.raises(IdentifiabilityError) as err:
        pipeline.identify(session.Session(table, data.meta), lm())
    assert str(err.value) == (
        "only 2 distinct fitting poses among 6: measure distinct, well-spread poses"
    )
    with pytest.raises(IdentifiabilityError, match="^1 fitting pose: at least 3 are needed$"):
        pipeline.identify(small(n=3), lm(validation_fraction=0.6))


# ------------------------------------------------------------------ results


def test_lsq_names_the_suspect_pose_by_its_number_and_warns():
    numbers = [100 + 3 * i for i in range(30)]
    result = pipeline.identify(small(n=30, noise_mm=0.01, numbers=numbers, bad=7), lm())
    assert result.outliers == [121]
    assert any(
        w == "pose(s) 121 fit far worse than the rest (possible outliers); consider --loss "
        "huber or trimmed"
        for w in result.warnings
    )
    assert result.loss == "lsq"


def test_trimmed_sets_the_bad_pose_aside_and_fits_the_rest():
    numbers = [5 * i for i in range(30)]
    data = small(n=30, noise_mm=0.01, numbers=numbers, bad=4)
    result = pipeline.identify(data, lm(loss="trimmed"))
    assert result.outliers == [20]
    assert result.details["robust"]["outliers"] == 1
    assert result.details["robust"]["evaluations"] > 0
    assert result.details["loss"] == "trimmed"
    assert not any("possible outliers" in w for w in result.warnings)
    # The fit ignores pose 20: its residual is the 3 mm it was moved, the rest at the noise.
    obs = data.observations
    dist = np.linalg.norm(measurement.errors(result.space, result.x, obs)[0], axis=1)
    assert dist[4] > 2.5 and np.delete(dist, 4).max() < 0.1
    # The uncertainty is that of the inliers: its sigma is at the noise, not the outlier.
    assert result.uncertainty["residual_sigma"]["position_mm"] < 0.02


def test_the_residual_noise_warning_names_the_sigma_above_twice_the_assumed():
    data = small(n=24, noise_mm=0.2)
    result = pipeline.identify(data, lm(noise_mm=0.05))
    sigma = result.uncertainty["residual_sigma"]["position_mm"]
    assert sigma > 0.1
    assert (
        f"the fit's residual noise {sigma:.3g} mm per axis is over 2 times the 0.05 mm "
        f"assumed when choosing the free parameters; rerun with --noise-mm {sigma:.2g} to "
        "judge them against it"
    ) in result.warnings
    # Assumed at the level found: no warning.
    calm = pipeline.identify(data, lm(noise_mm=sigma / 1.99))
    assert not any("residual noise" in w for w in calm.warnings)


def test_minimax_reports_the_worst_distance_of_the_arm_it_returns():
    data = small(n=16, noise_mm=0.05)
    result = pipeline.identify(data, lm(loss="minimax"))
    obs = data.observations
    dist = np.linalg.norm(measurement.errors(result.space, result.x, obs)[0], axis=1)
    assert result.details["minimax"]["worst_mm"] == pytest.approx(dist.max(), rel=1e-9)
    assert result.details["minimax"]["iterations"] > 0
    lsq = pipeline.identify(data, lm())
    lsq_dist = np.linalg.norm(measurement.errors(lsq.space, lsq.x, obs)[0], axis=1)
    assert dist.max() < lsq_dist.max()
    assert result.details["least_squares"]["evaluations"] > 0
    assert result.outliers == []


def test_result_frames_are_those_of_its_deltas():
    data = small(n=12)
    result = pipeline.identify(data, lm(validation_fraction=0.25))
    mdh, base, tool = result.space.unpack(result.x)
    np.testing.assert_array_equal(result.mdh, mdh)
    np.testing.assert_array_equal(result.base2tracker, base)
    np.testing.assert_array_equal(result.flange2tool, tool)
    assert len(result.fit_index) == 9 and len(result.validation_index) == 3
    assert result.stats["validation"]["after"]["n"] == 3
    assert result.stats["fit"]["before"]["n"] == 9
    # "before" is the nominal arm: its errors are the arm's true errors, far above "after".
    assert (
        result.stats["fit"]["before"]["position_mm"]["mean"]
        > 100 * result.stats["fit"]["after"]["position_mm"]["mean"]
    )


def test_least_squares_with_orientation_reports_the_weighted_sum_of_squares():
    data = small(n=10, noise_mm=0.05, orientation=True)
    obs = data.observations
    result = pipeline.identify(data, lm(k=400.0))
    ls = result.details["least_squares"]
    pose = kinematics.forward(result.mdh, obs.q, result.flange2tool, result.base2tracker)
    turn = Rotation.from_matrix(pose[:, :3, :3] @ np.swapaxes(obs.rotations, 1, 2)).as_rotvec()
    ssr = np.sum((pose[:, :3, 3] - obs.points) ** 2) + 400.0 * np.sum(turn**2)
    assert ls["objective"] == pytest.approx(ssr, rel=1e-6)
    assert isinstance(ls["message"], str) and ls["message"]
    assert ls["evaluations"] > 0
    # The orientation rows took part: the fit is not the position-only one.
    bare = pipeline.identify(data, lm(k=0.0))
    assert not np.allclose(bare.mdh, result.mdh, rtol=0, atol=1e-9)
