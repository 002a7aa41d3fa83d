"""The verdict's false alarms, and the smallest cause named for each kind of change."""

import re

import numpy as np
import pytest

from calibrator import session, simulate
from calibrator.calibration import Calibration
from calibrator.check import explain, verdict
from calibrator.check.model import Calibrated
from calibrator.identify import pipeline
from calibrator.model import frames, kinematics

NOISE_MM = 0.02  # RMS 3-D point noise of the calibration and of the checks


@pytest.fixture(scope="module")
def calibrated():
    """A ur10e calibrated on 40 simulated position-only poses (tracker frame), and its truth."""
    table, meta, truth = simulate.simulate(
        "ur10e", poses=40, seed=7, frame="tracker", orientation=False, noise_mm=NOISE_MM,
        errors="random", tool_offset_mm=1.5,
    )  # fmt: skip
    result = pipeline.identify(session.Session(table, meta), pipeline.Options(method="lm"))
    cal = Calibration.from_result(result, model="ur10e", frame="tracker")
    return Calibrated.of(cal), truth


def _measure(truth, q, rng, theta=None, base=None, tool=None):
    """Check points of the true arm (changed as asked), with the calibration's noise, mm."""
    mdh = truth.mdh.copy()
    if theta is not None:
        mdh[:, kinematics.THETA] += theta
    b2t = truth.base2tracker if base is None else truth.base2tracker @ base
    f2t = truth.flange2tool.copy()
    if tool is not None:
        f2t[:3, 3] += tool
    points = kinematics.forward(mdh, q, f2t, b2t)[:, :3, 3]
    return points + rng.normal(0.0, NOISE_MM / np.sqrt(3), points.shape)


def _poses(n=8, seed=1):
    return np.random.default_rng(seed).uniform(-2.5, 2.5, (n, 6))


def _judge(model, q, points):
    cov = verdict.covariance(model.covariance(q), None, model.sigma_mm)
    return verdict.judge(points - model.points(q), cov), cov


def test_an_unchanged_arm_rarely_raises_an_alarm(calibrated):
    model, truth = calibrated
    rng = np.random.default_rng(0)
    q = _poses()
    results = [_judge(model, q, _measure(truth, q, rng))[0] for _ in range(300)]
    alarms = sum(r.verdict != "ok" for r in results)
    assert alarms <= 3, alarms  # ALARM_P = 1e-3 per check; 3 of 300 is far beyond it
    # The predicted mean error is what an unchanged arm shows.
    ratio = np.mean([r.measured_mm for r in results]) / np.mean([r.predicted_mm for r in results])
    assert 0.8 <= ratio <= 1.2, ratio


@pytest.mark.parametrize("joint", [2, 3, 4, 5])
def test_a_crashed_joint_is_named_with_its_shift(calibrated, joint):
    model, truth = calibrated
    q = _poses()
    shift = np.zeros(6)
    shift[joint - 1] = 4e-4
    points = _measure(truth, q, np.random.default_rng(joint), theta=shift)
    judged, cov = _judge(model, q, points)
    assert judged.verdict == "recalibrate"
    best, tried = explain.explain(model, q, points, cov)
    assert best is not None and best.causes == (f"joint {joint} zero",)
    assert abs(best.value[0] - 4e-4) < 5 * best.se[0] + 2e-5, (best.value, best.se)
    assert re.fullmatch(
        rf"joint {joint} zero moved \+0\.[34]\d\d ± 0\.0\d\d mrad: "
        rf"re-master J{joint} or recalibrate",
        best.sentences()[0],
    )
    assert len(tried) == len(explain.CAUSES)  # one cause explained it: no pairs tried


def test_a_moved_base_and_a_moved_reflector_are_named(calibrated):
    model, truth = calibrated
    q = _poses()
    points = _measure(
        truth, q, np.random.default_rng(5), base=frames.transform(translation=[0.3, 0, 0])
    )
    best, _ = explain.explain(model, q, points, _judge(model, q, points)[1])
    assert best is not None and best.causes == ("base",)
    assert "the base moved 0.30" in best.sentences()[0]
    points = _measure(truth, q, np.random.default_rng(6), tool=np.array([0.0, 0.2, 0.0]))
    best, _ = explain.explain(model, q, points, _judge(model, q, points)[1])
    assert best is not None and best.causes == ("reflector",)


def test_two_crashed_joints_are_named_as_a_pair(calibrated):
    model, truth = calibrated
    q = _poses(10)
    points = _measure(truth, q, np.random.default_rng(8), theta=np.array([0, 3e-4, 0, -5e-4, 0, 0]))
    best, _ = explain.explain(model, q, points, _judge(model, q, points)[1])
    assert best is not None and set(best.causes) == {"joint 2 zero", "joint 4 zero"}


def test_a_small_change_is_drifted_and_a_tolerance_moves_the_limit(calibrated):
    model, truth = calibrated
    q = _poses()
    shift = np.array([0, 0, 6e-5, 0, 0, 0])
    points = _measure(truth, q, np.random.default_rng(3), theta=shift)
    cov = verdict.covariance(model.covariance(q), None, model.sigma_mm)
    judged = verdict.judge(points - model.points(q), cov)
    assert judged.verdict == "drifted", judged
    assert judged.measured_mm <= judged.limit_mm == pytest.approx(2 * judged.predicted_mm)
    tight = verdict.judge(points - model.points(q), cov, tolerance_mm=judged.measured_mm / 2)
    assert tight.verdict == "recalibrate"


def test_the_checks_own_tracker_noise_widens_the_covariance():
    cov = verdict.covariance(np.eye(6) * 1e-4, np.full((2, 3), 0.02), sigma_mm=0.01)
    np.testing.assert_allclose(np.diag(cov), 1e-4 + 0.02**2 - 0.01**2)
    assert np.array_equal(verdict.covariance(np.eye(6), np.full((2, 3), 1e-3), 0.01), np.eye(6))
