"""Joint error terms: the maps, gravity torques, and recovery on simulated arms that have them."""

import numpy as np
import pytest
from joint_kit import geometric_fit, merged, sessions

from calibrator import robots
from calibrator.errors import CalibrationError
from calibrator.identify import joint_fit
from calibrator.identify.problem import Problem
from calibrator.model import joint_terms, kinematics, measurement
from calibrator.model.parameters import ParameterSpace
from calibrator.robots import masses as robot_masses


def _terms(scale=None, cos=None, sin=None, comp=None):
    z = np.zeros(6)
    return joint_terms.JointTerms(
        *(z.copy() if v is None else np.asarray(v, dtype=float) for v in (scale, cos, sin, comp))
    )


def test_gravity_torque_is_minus_the_gradient_of_potential_energy():
    """tau_j = -dU/dq_j, U = sum m g z_com (+ payload): an independent check by differences."""
    robot, masses = robots.get("ur10e"), robot_masses.get("ur10e")
    q = np.random.default_rng(0).uniform(-np.pi, np.pi, (5, 6))
    com_payload = np.array([10.0, -5.0, 100.0])

    def energy(qq):
        _, fr = kinematics.chain(robot.mdh, qq, all_frames=True)
        z = np.einsum("nkj,kj->nk", fr[:, 1:, 2, :3], masses.com_mm) + fr[:, 1:, 2, 3]
        zp = fr[:, 6, 2, :3] @ com_payload + fr[:, 6, 2, 3]
        return 9.81 * (z @ masses.mass_kg + 4.0 * zp) / 1000.0  # N m

    tau = joint_terms.gravity_torques(robot.mdh, q, masses, 4.0, com_payload)
    eps = 1e-6
    for j in range(6):
        step = np.zeros(6)
        step[j] = eps
        grad = (energy(q + step) - energy(q - step)) / (2 * eps)
        np.testing.assert_allclose(tau[:, j], -grad, atol=1e-5)
    assert np.abs(tau[:, 1]).max() > 10.0  # the shoulder carries real load


def test_effective_angles_and_their_derivatives():
    rng = np.random.default_rng(1)
    q, tau = rng.uniform(-3, 3, (7, 6)), rng.normal(0, 50, (7, 6))
    t = rng.normal(0, 1e-3, 24)
    got = joint_terms.effective(q, t, tau)
    s, c, d, k = t.reshape(4, 6)
    np.testing.assert_allclose(got, q * (1 + s) + c * np.cos(q) + d * np.sin(q) + k * tau)
    eps = 1e-7
    numeric = np.stack(
        [(joint_terms.effective(q, t + eps * e, tau) - got) / eps for e in np.eye(24)], axis=-1
    )  # (7, 6, 24)
    want = joint_terms.derivatives(q, tau)  # (7, 24): term i acts on joint i % 6
    for i in range(24):
        np.testing.assert_allclose(numeric[:, i % 6, i], want[:, i], rtol=1e-5, atol=1e-8)
    with pytest.raises(CalibrationError, match="torque"):
        joint_terms.effective(q, np.r_[np.zeros(18), np.ones(6)])


def test_measurement_jacobian_of_joint_terms_matches_differences():
    robot, masses = robots.get("ur10e"), robot_masses.get("ur10e")
    rng = np.random.default_rng(2)
    q = rng.uniform(-np.pi, np.pi, (12, 6))
    tau = joint_terms.gravity_torques(robot.mdh, q, masses, 3.0)
    free = ("a2", "theta3", "tool_x", "scale5", "hcos2", "hsin6", "comp2", "comp3")
    space = ParameterSpace(robot.mdh, free=free)
    x = rng.normal(size=space.size) * [0.1, 1e-3, 1.0, 1e-3, 1e-3, 1e-3, 1e-6, 1e-6]
    pose = measurement.predict(space, x, q, tau)
    obs = measurement.Observations(q, pose[:, :3, 3], pose[:, :3, :3], tau)
    problem = Problem.of(space, obs, 1e4)
    jac = problem.jacobian(x)
    eps = 1e-7
    cols = [
        (problem.residuals(x + eps * e) - problem.residuals(x - eps * e)) / (2 * eps)
        for e in np.eye(space.size)
    ]
    np.testing.assert_allclose(jac, np.column_stack(cols), rtol=1e-5, atol=1e-6)


def _fit(truth_terms, groups, payloads=(0.0,), poses=60, seed=5, validation=0.25):
    parts, _ = sessions(truth_terms, poses=poses, seed=seed, payloads_kg=payloads)
    geo, result, _ = _fit_parts(parts, groups, validation, noise_mm=0.02)
    return geo, result


def _fit_parts(parts, groups, validation, noise_mm):
    """Geometry first, then the joint terms of ``groups`` on the same split of ``parts``.

    Returns the geometric fit, the joint-terms fit and the (fit, validation) observations.
    """
    sess, tau, payload = merged(parts)
    geo = geometric_fit(sess, validation, noise_mm=noise_mm)
    o = sess.observations
    obs = measurement.Observations(o.q, o.points, o.rotations, tau)
    fit_obs, val_obs = obs.subset(geo.fit_index), obs.subset(geo.validation_index)
    result = joint_fit.fit(
        Problem.of(geo.space, fit_obs, geo.k),
        geo.x,
        val_obs,
        groups,
        noise_mm,
        payload[geo.fit_index],
    )
    return geo, result, (fit_obs, val_obs)


def _recovered(result, truth_terms):
    """Every identified term against the truth, in standard errors."""
    truth = dict(zip(joint_terms.NAMES, truth_terms.vector(), strict=True))
    se = result.uncertainty["standard_errors"]
    values = dict(zip(result.space.free, result.x, strict=True))
    return {n: (values[n] - truth[n]) / se[n] for n in values if n in joint_terms.NAMES}


def test_wrist_gear_ratio_errors_are_recovered_within_their_standard_errors():
    truth = _terms(scale=[0, 0, 0, 1e-3, 2e-3, -1.5e-3])
    geo, result = _fit(truth, ("scale",))
    assert result.kept == ("scale",)
    z = _recovered(result, truth)
    assert set(z) == {f"scale{j}" for j in range(1, 7)}
    assert max(abs(v) for v in z.values()) < 2.0, z
    # And it pays on poses the fit did not see.
    held = result.stats["validation"]["after"]["position_mm"]["mean"]
    assert held < 0.05 < geo.stats["validation"]["after"]["position_mm"]["mean"]


def test_harmonic_errors_are_recovered_within_their_standard_errors():
    truth = _terms(cos=[0, 1.5e-3, 0, 0, 0, 0], sin=[0, 0, -1e-3, 0, 8e-4, 0])
    _, result = _fit(truth, ("harmonic",))
    assert result.kept == ("harmonic",)
    z = _recovered(result, truth)
    assert {"hcos2", "hsin3", "hsin5"} <= set(z)
    assert max(abs(v) for v in z.values()) < 2.0, z


def test_compliance_is_recovered_from_two_payloads():
    truth = _terms(comp=[0, 3e-6, 5e-6, 0, 0, 0])
    _, result = _fit(truth, ("compliance",), payloads=(0.0, 10.0), poses=40)
    assert result.kept == ("compliance",)
    z = _recovered(result, truth)
    assert {"comp2", "comp3"} <= set(z)
    assert max(abs(v) for v in z.values()) < 2.0, z


def test_compliance_at_one_payload_is_refused_with_its_reason():
    truth = _terms(comp=[0, 3e-6, 5e-6, 0, 0, 0])
    _, result = _fit(truth, ("compliance",), payloads=(5.0,))
    assert result.kept == ()
    assert "one payload" in result.decisions[0]["reason"]


def test_terms_are_not_kept_on_an_arm_without_them():
    geo, result = _fit(_terms(), ("scale", "harmonic"), seed=11)
    assert result.kept == ()
    assert [d["kept"] for d in result.decisions] == [False, False]
    after = result.stats["validation"]["after"]["position_mm"]["mean"]
    assert after <= 1.05 * geo.stats["validation"]["after"]["position_mm"]["mean"]


def test_joint_terms_json_round_trip_and_bad_entries():
    t = _terms(scale=np.arange(6) * 1e-4, cos=np.ones(6) * 1e-4, comp=np.ones(6) * 1e-6)
    back = joint_terms.JointTerms.from_json(t.to_json())
    np.testing.assert_array_equal(back.vector(), t.vector())
    assert not joint_terms.JointTerms.from_json(None).used
    with pytest.raises(CalibrationError, match="scale"):
        joint_terms.JointTerms.from_json({"scale": [1, 2]})
    with pytest.raises(CalibrationError, match="--joint-terms"):
        joint_terms.parse_groups("scale,gearbox")
    assert joint_terms.parse_groups("harmonic, scale") == ("harmonic", "scale")


def test_a_huge_kept_term_is_warned_about():
    truth = _terms(scale=[0, 0, 0, 0, 0.03, 0])  # 3 %: no gearbox is that far off
    _, result = _fit(truth, ("scale",))
    assert result.kept == ("scale",)
    (line,) = joint_fit.implausible_terms(result)
    assert line.startswith("joint term scale5 = 0.03")


@pytest.mark.parametrize("wrist", [True, False])
def test_held_out_error_against_least_squares_from_the_truth(wrist):
    """W1's shape: with wrist gear errors the terms reach least squares from the truth
    and beat the geometry twice over; without, they are not kept and cost nothing."""
    from joint_kit import sessions as make

    from calibrator.identify import refine

    scale = np.array([0, 0, 0, 1.5e-3, -2e-3, 1e-3]) if wrist else np.zeros(6)
    parts, truth = make(_terms(scale=scale), poses=50, seed=21, noise_mm=0.03)
    geo, result, (fit_obs, val_obs) = _fit_parts(parts, ("scale",), 0.3, noise_mm=0.03)
    held = result.stats["validation"]["after"]["position_mm"]["mean"]
    geometric = geo.stats["validation"]["after"]["position_mm"]["mean"]
    # Least squares started at the truth, geometry plus scale terms.
    names = list(geo.space.free) + list(joint_terms.names_of(("scale",)))
    space = result.space.with_free(names)
    start = space.pack(truth["mdh"], np.eye(4), truth["tool"])
    start[[names.index(f"scale{j + 1}") for j in range(6)]] = scale
    best = refine.refine(Problem.of(space, fit_obs, geo.k), start).x
    from_truth = np.linalg.norm(measurement.errors(space, best, val_obs)[0], axis=1).mean()
    if wrist:
        assert result.kept == ("scale",)
        assert held <= 1.3 * from_truth
        assert geometric >= 2 * held
    else:
        assert result.kept == ()
        assert held <= 1.05 * geometric
