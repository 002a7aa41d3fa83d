"""The check's explanation of a crash of every joint, of the base, and where they look alike.

``tests/check/test_verdict_explain.py`` crashes joints 2 to 5. Joint 1's
zero and a turn of the base about joint 1's axis move every point alike; so
do joint 6's zero and the reflector turned about the flange axis. The
explanation's documented answer (calibrator/check/explain.py) is the cause
with the fewest parameters, the joint, with the look-alike said in the same
sentence. A moved base (turned about another axis, shifted) is the base.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from calibrator import session, simulate
from calibrator.calibration import Calibration
from calibrator.check import explain, verdict
from calibrator.check.model import Calibrated
from calibrator.identify import pipeline
from calibrator.model import frames, kinematics, rotations

NOISE_MM = 0.02
#: Reflector this far off the flange axis (mm): joint 6's zero is seen through it.
OFFSET_MM = 60.0


@pytest.fixture(scope="module")
def calibrated():
    """A ur10e calibrated on 40 simulated position-only poses, the reflector off axis."""
    table, meta, truth = simulate.simulate(
        "ur10e", poses=40, seed=7, frame="tracker", orientation=False, noise_mm=NOISE_MM,
        errors="random", tool_offset_mm=OFFSET_MM,
    )  # fmt: skip
    result = pipeline.identify(session.Session(table, meta), pipeline.Options(method="lm"))
    cal = Calibration.from_result(result, model="ur10e", frame="tracker")
    return Calibrated.of(cal), truth


def _measure(truth, q, seed, theta=None, base=None):
    mdh = truth.mdh.copy()
    if theta is not None:
        mdh[:, kinematics.THETA] += theta
    b2t = truth.base2tracker if base is None else truth.base2tracker @ base
    points = kinematics.forward(mdh, q, truth.flange2tool, b2t)[:, :3, 3]
    return points + np.random.default_rng(seed).normal(0.0, NOISE_MM / np.sqrt(3), points.shape)


def _poses(n=10, seed=1):
    return np.random.default_rng(seed).uniform(-2.5, 2.5, (n, 6))


def _explained(model, q, points):
    cov = verdict.covariance(model.covariance(q), None, model.sigma_mm)
    judged = verdict.judge(points - model.points(q), cov)
    best, tried = explain.explain(model, q, points, cov)
    return judged, best, {f.causes: f for f in tried}


#: What each joint's sentence adds: the look-alike cause, if any.
ALSO = {
    1: " (or the base turned about joint 1's axis)",
    6: " (or the reflector turned about the flange axis)",
}


@pytest.mark.parametrize("joint", [1, 2, 3, 4, 5, 6])
def test_a_crash_of_each_joint_is_named_with_its_shift_and_its_look_alike(calibrated, joint):
    model, truth = calibrated
    q = _poses()
    # Joint 6 turns the reflector about the flange axis, a few cm from it: a larger crash.
    size = 3e-3 if joint == 6 else 5e-4
    shift = np.zeros(6)
    shift[joint - 1] = -size
    judged, best, tried = _explained(model, q, _measure(truth, q, 10 + joint, theta=shift))
    assert judged.verdict == "recalibrate"
    assert best is not None and best.causes == (f"joint {joint} zero",), best
    assert abs(best.value[0] + size) < 5 * best.se[0] + 2e-5, (best.value, best.se)
    sentence = best.sentences()[0]
    assert sentence == (
        f"joint {joint} zero moved {best.value[0] * 1e3:+.3f} ± {best.se[0] * 1e3:.3f} mrad"
        f"{ALSO.get(joint, '')}: re-master J{joint} or recalibrate"
    )
    # Every other single joint leaves errors the check does not pass.
    for other in set(range(1, 7)) - {joint}:
        assert not tried[(f"joint {other} zero",)].explains, other


def test_joint_1_and_a_base_turned_about_its_axis_are_told_apart_honestly(calibrated):
    """Both explain a joint-1 crash; the joint (one parameter) is named, the base said too."""
    model, truth = calibrated
    q = _poses()
    shift = np.array([4e-4, 0, 0, 0, 0, 0])
    _, best, tried = _explained(model, q, _measure(truth, q, 21, theta=shift))
    assert best.causes == ("joint 1 zero",)
    assert tried[("base",)].explains  # the look-alike is real: hence the sentence's note
    assert "(or the base turned about joint 1's axis)" in best.sentences()[0]
    # The base turned by the same angle about z: the same points, the same answer.
    turned = frames.transform(rotations.rotvec_to_matrix([0.0, 0.0, 4e-4]))
    _, best_base, _ = _explained(model, q, _measure(truth, q, 21, base=turned))
    assert best_base.causes == ("joint 1 zero",)
    assert abs(best_base.value[0] - best.value[0]) < 3 * best.se[0]


@pytest.mark.parametrize(
    ("turn", "shift", "mm"),
    [([4e-4, 0.0, 0.0], [0.0, 0.0, 0.0], 0.0), ([0.0, 0.0, 0.0], [0.0, 0.0, 0.25], 0.25),
     ([0.0, -3e-4, 0.0], [0.15, 0.0, 0.0], 0.15)],
)  # fmt: skip
def test_a_moved_base_is_named_with_its_shift_and_turn(calibrated, turn, shift, mm):
    """Turned about x or y, or shifted (along z too): no joint explains it, the base does."""
    model, truth = calibrated
    q = _poses()
    moved = frames.transform(rotations.rotvec_to_matrix(turn), shift)
    judged, best, tried = _explained(model, q, _measure(truth, q, 31, base=moved))
    assert judged.verdict == "recalibrate"
    assert best is not None and best.causes == ("base",), best
    assert not any(tried[(f"joint {j} zero",)].explains for j in range(1, 7))
    sentence = best.sentences()[0]
    found = re.match(
        r"the base moved ([\d.]+) ± ([\d.]+) mm and turned ([\d.]+) ± ([\d.]+) mrad", sentence
    )
    assert found, sentence
    moved_mm, se_mm, turned_mrad, se_mrad = map(float, found.groups())
    assert abs(moved_mm - mm) < 4 * se_mm + 0.02, sentence
    assert abs(turned_mrad - 1e3 * np.linalg.norm(turn)) < 4 * se_mrad + 0.02, sentence
    assert sentence.endswith(
        "re-register the base (or the tracker moved) and re-check, or recalibrate"
    )
