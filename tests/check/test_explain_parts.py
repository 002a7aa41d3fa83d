"""The explanation's parts read exactly: its sentences, its JSON, its fits' statistics.

What ``mutmut`` left alive in calibrator/check/explain.py after the crash
tests: the reflector's and the base's sentences to the digit, the JSON a
check document carries, the degrees of freedom of each fit's p-value, the
combinations too large for the poses (skipped, the rest still tried), a
cause the poses cannot see (joint 6 with the reflector on its axis), and a
change no pair of causes explains.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from calibrator import session, simulate
from calibrator.calibration import Calibration
from calibrator.check import explain, verdict
from calibrator.check.model import Calibrated
from calibrator.identify import pipeline
from calibrator.model import frames, kinematics, parameters

NOISE_MM = 0.02


@pytest.fixture(scope="module")
def calibrated():
    table, meta, truth = simulate.simulate(
        "ur10e", poses=40, seed=7, frame="tracker", orientation=False, noise_mm=NOISE_MM,
        errors="random", tool_offset_mm=60.0,
    )  # fmt: skip
    result = pipeline.identify(session.Session(table, meta), pipeline.Options(method="lm"))
    cal = Calibration.from_result(result, model="ur10e", frame="tracker")
    return Calibrated.of(cal), truth


def _measure(truth, q, seed, theta=None, tool=None):
    mdh = truth.mdh.copy()
    if theta is not None:
        mdh[:, kinematics.THETA] += theta
    f2t = truth.flange2tool if tool is None else tool
    points = kinematics.forward(mdh, q, f2t, truth.base2tracker)[:, :3, 3]
    return points + np.random.default_rng(seed).normal(0.0, NOISE_MM / np.sqrt(3), points.shape)


def _cov(model, q):
    return verdict.covariance(model.covariance(q), None, model.sigma_mm)


def _poses(n, seed=1):
    return np.random.default_rng(seed).uniform(-2.5, 2.5, (n, 6))


def test_the_reflectors_and_the_bases_sentences_to_the_digit():
    reflector = explain.Fit(
        ("reflector",), parameters.TOOL_NAMES, np.array([0.3, 0.4, 0.0]),
        np.array([0.01, 0.02, 0.03]), 4.0, 0.5,
    )  # fmt: skip
    # |v| = 0.5; se = sqrt((0.6 * 0.01)^2 + (0.8 * 0.02)^2) = 0.01709
    assert reflector.sentences() == [
        "the reflector moved 0.500 ± 0.017 mm on the flange: "
        "re-seat the reflector (or re-identify the tool), or recalibrate"
    ]
    base = explain.Fit(
        ("base",), parameters.BASE_NAMES, np.array([0.0, 0.0, 0.2, 3e-3, -4e-3, 0.0]),
        np.array([0.01, 0.01, 0.05, 6e-3, 2e-3, 1e-5]), 4.0, 0.5,
    )  # fmt: skip
    # Turned 5 mrad; se = sqrt((0.6 * 6)^2 + (0.8 * 2)^2) = 3.9395 mrad.
    assert base.sentences() == [
        "the base moved 0.200 ± 0.050 mm and turned 5.000 ± 3.940 mrad: "
        "re-register the base (or the tracker moved) and re-check, or recalibrate"
    ]
    still = explain.Fit(("reflector",), parameters.TOOL_NAMES, np.zeros(3),
                        np.array([0.03, 0.04, 0.0]), 1.0, 0.9)  # fmt: skip
    assert still.sentences()[0].startswith("the reflector moved 0.000 ± 0.050 mm")


def test_a_pair_of_causes_reads_each_its_own_parameters_and_goes_to_json():
    fit = explain.Fit(
        ("joint 2 zero", "reflector"), ("theta2", *parameters.TOOL_NAMES),
        np.array([-2e-4, 0.0, 0.6, 0.8]), np.array([1e-5, 0.1, 0.1, 0.1]), 12.5, 0.25,
    )  # fmt: skip
    assert fit.sentences() == [
        "joint 2 zero moved -0.200 ± 0.010 mrad: re-master J2 or recalibrate",
        "the reflector moved 1.000 ± 0.100 mm on the flange: "
        "re-seat the reflector (or re-identify the tool), or recalibrate",
    ]
    assert fit.aic == pytest.approx(12.5 + 2 * 4)
    assert fit.explains == (0.25 >= verdict.ALARM_P)
    doc = fit.to_json()
    assert doc == {
        "causes": ["joint 2 zero", "reflector"],
        "parameters": [
            {"name": "theta2", "change": -2e-4, "standard_error": 1e-5, "unit": "rad"},
            {"name": "tool_x", "change": 0.0, "standard_error": 0.1, "unit": "mm"},
            {"name": "tool_y", "change": 0.6, "standard_error": 0.1, "unit": "mm"},
            {"name": "tool_z", "change": 0.8, "standard_error": 0.1, "unit": "mm"},
        ],
        "chi2": 12.5,
        "p_value": 0.25,
        "explains": True,
        "text": fit.sentences(),
    }
    assert not explain.Fit(("base",), parameters.BASE_NAMES, np.zeros(6), np.ones(6), 99.0,
                           verdict.ALARM_P / 2).to_json()["explains"]  # fmt: skip


def test_each_fits_p_value_has_three_per_pose_less_its_parameters(calibrated):
    model, truth = calibrated
    q = _poses(8)
    points = _measure(truth, q, 3, theta=np.array([0, 0, 5e-4, 0, 0, 0]))
    _, tried = explain.explain(model, q, points, _cov(model, q))
    assert model.noise_dof is not None
    for fit in tried:
        dof = 3 * len(q) - len(fit.names)
        assert fit.p_value == pytest.approx(verdict.p_value(fit.chi2, dof, model.noise_dof))


def test_a_change_no_pair_explains_tries_every_single_cause_and_pair_and_names_none(calibrated):
    model, truth = calibrated
    q = _poses(12, seed=4)
    crash = np.array([6e-4, -5e-4, 0.0, 7e-4, 0.0, 0.0])  # three joints at once
    points = _measure(truth, q, 5, theta=crash)
    best, tried = explain.explain(model, q, points, _cov(model, q))
    assert best is None
    n = len(explain.CAUSES)
    assert len(tried) == n + n * (n - 1) // 2  # singles, then pairs; no triples by default
    assert [f.causes for f in tried[:n]] == [(c,) for c, _ in explain.CAUSES]
    three, _ = explain.explain(model, q, points, _cov(model, q), max_causes=3)
    assert three is not None and set(three.causes) == {"joint 1 zero", "joint 2 zero",
                                                       "joint 4 zero"}  # fmt: skip


def test_causes_with_more_parameters_than_the_poses_hold_are_skipped_the_rest_tried(calibrated):
    model, truth = calibrated
    q = _poses(2, seed=6)  # six numbers: the base (6) leaves none to judge it by
    two = np.array([0.0, 5e-3, 0.0, -5e-3, 0.0, 0.0])  # no single cause explains it: pairs too
    points = _measure(truth, q, 7, theta=two)
    _, tried = explain.explain(model, q, points, _cov(model, q))
    sizes = {f.causes: len(f.names) for f in tried}
    assert ("base",) not in sizes and ("reflector",) in sizes
    assert all(3 * len(q) - k >= 1 for k in sizes.values())
    assert ("joint 1 zero", "reflector") in sizes  # four of six: tried
    one = q[:1]  # three numbers: joints alone and in pairs, not the reflector
    _, tried = explain.explain(model, one, _measure(truth, one, 8, theta=two), _cov(model, one))
    causes = {f.causes for f in tried}
    assert ("reflector",) not in causes and ("joint 1 zero", "joint 2 zero") in causes


def test_joint_6_with_the_reflector_on_its_axis_is_not_a_cause(calibrated):
    model, truth = calibrated
    on_axis = frames.transform(translation=[0.0, 0.0, 100.0])
    space = model.space
    blind = dataclasses.replace(
        model,
        space=parameters.ParameterSpace(space.nominal_mdh, space.base0, on_axis, space.free),
    )
    q = _poses(8)
    points = _measure(truth, q, 9, tool=on_axis)
    _, tried = explain.explain(blind, q, points, _cov(blind, q))
    singles = {f.causes[0] for f in tried if len(f.causes) == 1}
    assert "joint 6 zero" not in singles
    assert singles == {c for c, _ in explain.CAUSES} - {"joint 6 zero"}
