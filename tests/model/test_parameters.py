"""Masks, pack/unpack, the measurement Jacobian and identifiability pruning."""

import numpy as np
import pytest

from calibrator import robots
from calibrator.model import frames, measurement, parameters, rotations
from calibrator.model.parameters import ALL_NAMES, ParameterSpace

IPSO_PAPER_24 = [
    "a1",
    "a2",
    "a3",
    "a4",
    "a5",
    "a6",
    "d1",
    "d3",
    "d4",
    "d5",
    "d6",
    "alpha1",
    "alpha2",
    "alpha3",
    "alpha4",
    "alpha5",
    "alpha6",
    "beta2",
    "theta1",
    "theta2",
    "theta3",
    "theta4",
    "theta5",
    "theta6",
]


def random_frame(rng, distance_mm):
    return frames.transform(
        rotations.rotvec_to_matrix(rng.uniform(-2, 2, 3)), rng.normal(0, distance_mm, 3)
    )


def test_pack_unpack_round_trip_every_parameter():
    rng = np.random.default_rng(11)
    space = ParameterSpace(
        robots.get("ur10e").mdh, random_frame(rng, 2000), random_frame(rng, 100), ALL_NAMES
    )
    for _ in range(5):
        x = rng.normal(0, 0.05, space.size)
        assert np.allclose(space.pack(*space.unpack(x)), x, atol=1e-12)


def test_unpack_of_a_swarm_equals_unpack_of_each_particle():
    rng = np.random.default_rng(12)
    space = ParameterSpace(
        robots.get("er10l-c10").mdh,
        random_frame(rng, 2000),
        np.eye(4),
        ("a2", "beta2", "base_rx", "base_tz", "tool_y"),
    )
    swarm = rng.normal(0, 0.1, (7, space.size))
    mdh, base, tool = space.unpack(swarm)
    assert mdh.shape == (7, 6, 5) and base.shape == (7, 4, 4) and tool.shape == (7, 4, 4)
    for i in (0, 6):
        for got, want in zip((mdh[i], base[i], tool[i]), space.unpack(swarm[i]), strict=True):
            np.testing.assert_allclose(got, want)


def test_pack_ignores_differences_in_fixed_parameters():
    nominal = robots.get("er10l-c10").mdh
    space = ParameterSpace(nominal, free=("a1", "theta6"))
    mdh = nominal.copy()
    mdh[0, 0] += 0.3  # a1, free
    mdh[3, 3] += 9.0  # d4, fixed
    np.testing.assert_allclose(space.pack(mdh), [0.3, 0.0])


@pytest.mark.parametrize("orientation", [False, True])
def test_jacobian_matches_finite_differences(orientation):
    rng = np.random.default_rng(13)
    space = ParameterSpace(
        robots.get("er10l-c10").mdh, random_frame(rng, 3000), random_frame(rng, 150), ALL_NAMES
    )
    q = rng.uniform(-np.pi, np.pi, (9, 6))
    x = rng.normal(0, 0.01, space.size)
    pose = measurement.predict(space, x, q)
    obs = measurement.Observations(
        q, pose[:, :3, 3].copy(), pose[:, :3, :3].copy() if orientation else None
    )
    k = 1e4
    jac = measurement.jacobian(space, x, obs, k)
    h = 1e-6
    numeric = np.column_stack(
        [
            (
                measurement.residuals(space, x + h * e, obs, k)
                - measurement.residuals(space, x - h * e, obs, k)
            )
            / (2 * h)
            for e in np.eye(space.size)
        ]
    )
    assert jac.shape == numeric.shape == (len(q) * (6 if orientation else 3), len(ALL_NAMES))
    np.testing.assert_allclose(jac, numeric, atol=1e-5 * np.abs(numeric).max())


def prune_for(model, frame, tool_known, orientation, n_poses=30, seed=5):
    rng = np.random.default_rng(seed)
    nominal = robots.get(model).mdh
    base = random_frame(rng, 3000) if frame == "tracker" else np.eye(4)
    tool = frames.transform(translation=[20.0, -10.0, 120.0])
    candidates, structural = parameters.structural_candidates(nominal, frame, tool_known)
    space = ParameterSpace(nominal, base, tool, candidates)
    q = rng.uniform(-np.pi, np.pi, (n_poses, 6))
    pose = measurement.predict(space, np.zeros(space.size), q)
    obs = measurement.Observations(q, pose[:, :3, 3], pose[:, :3, :3] if orientation else None)
    jac = measurement.jacobian(space, np.zeros(space.size), obs, 1e4, names=candidates)
    kept, pruned = parameters.prune(candidates, jac)
    return kept, structural, pruned


def test_seed_robot_in_base_frame_with_orientation_keeps_the_seeds_24():
    kept, structural, pruned = prune_for("er10l-c10", "base", True, True)
    assert sorted(kept) == sorted(IPSO_PAPER_24)
    assert sorted(d["name"] for d in structural) == [
        "beta1",
        "beta3",
        "beta4",
        "beta5",
        "beta6",
        "d2",
    ]
    assert pruned == []


def test_parallel_axis_robot_drops_exactly_the_redundant_parameters():
    # UR10e: axes 2, 3, 4 parallel; unknown base frame and tool point; points only.
    kept, structural, pruned = prune_for("ur10e", "tracker", False, False)
    assert sorted(d["name"] for d in structural) == ["beta1", "beta4", "beta5", "beta6", "d2", "d3"]
    # Base frame absorbs joint 1's slide and turn; the tool point absorbs
    # everything joint 6 does to a point.
    assert sorted(d["name"] for d in pruned) == ["a6", "alpha6", "d1", "d6", "theta1", "theta6"]
    by_name = {d["name"]: d["reason"] for d in pruned}
    assert "base_tz" in by_name["d1"] and "base_rz" in by_name["theta1"]
    assert "tool_" in by_name["d6"]
    # 4 R + 6 - 3 (points only) = 27 identifiable parameters.
    assert len(kept) == 27


def test_orientation_makes_the_last_joints_turns_identifiable():
    kept, _, pruned = prune_for("ur10e", "tracker", False, True)
    assert {"theta6", "alpha6"} <= set(kept)
    assert sorted(d["name"] for d in pruned) == ["a6", "d1", "d6", "theta1"]


def test_too_few_poses_is_refused():
    with pytest.raises(parameters.IdentifiabilityError, match="24 free parameters"):
        parameters.require_enough(18, 24)


def test_full_tool_frame_replaces_joint_6_constant_part():
    nominal = robots.get("ur10e").mdh
    with_rot, dropped = parameters.structural_candidates(nominal, "tracker", False, True)
    assert {"tool_rx", "tool_ry", "tool_rz", "tool_x"} <= set(with_rot)
    assert not {"a6", "alpha6", "theta6", "d6", "beta6"} & set(with_rot)
    reasons = {d["name"]: d["reason"] for d in dropped}
    assert "tool frame" in reasons["theta6"]
    # Without orientation, or with the tool known, the tool rotation is not identified.
    points_only, _ = parameters.structural_candidates(nominal, "tracker", False, False)
    known, _ = parameters.structural_candidates(nominal, "tracker", True, True)
    assert "tool_rx" not in points_only and "theta6" in points_only
    assert not any(n.startswith("tool_") for n in known) and "theta6" in known


def test_a_round_off_column_has_no_effect_rather_than_being_kept():
    # A parameter with no real effect comes out of the chain as round-off, not 0
    # (e.g. theta4 when joint 5 never moves and the tool point is on axis 6).
    rng = np.random.default_rng(0)
    jac = rng.normal(size=(30, 3)) * [1.0, 500.0, 2.0]
    jac[:, 1] = rng.normal(size=30) * 1e-13
    kept, dropped = parameters.prune(["a1", "theta4", "d4"], jac)
    assert kept == ["a1", "d4"]
    assert dropped == [{"name": "theta4", "reason": "has no effect on any measured pose"}]
