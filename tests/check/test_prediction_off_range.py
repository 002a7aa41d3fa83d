"""The predicted held-out error holds off the fitted poses, for position-only data as for 6-DoF.

The public data set's case, simulated: an arm in the tracker frame (base and
tool unknown), 10 poses fitted from 0.6 times the joint ranges, the other 20
from the whole ranges (many outside the fitted ones), with a geometric arm
and with an error the geometric model lacks (joint compliance under a 5 kg
payload). Ten poses identify fewer joint parameters than thirty; the ones
left out (``... with these poses``) still differ from nominal on the real
arm, and the prediction carries their prior (the identified joint deltas'
spread, empirical Bayes) through the part the fit cannot absorb. Before it,
a position-only fit predicted 0.74 of the observed error off its range.
Pooled over 16 arms, every case is within 20 %.
"""

import numpy as np
import pytest

from calibrator import robots, session, simulate
from calibrator.identify import pipeline, uncertainty
from calibrator.identify.problem import Problem
from calibrator.model import frames, joint_terms, kinematics, measurement, rotations
from calibrator.robots import masses as robot_masses

#: Joint compliance of joints 2 and 3 (rad per N m): an error the geometric model lacks.
COMPLIANT = joint_terms.JointTerms(
    np.zeros(6), np.zeros(6), np.zeros(6), np.array([0, 2e-6, 3e-6, 0, 0, 0])
)
GEOMETRIC = joint_terms.JointTerms.zero()


def _session(seed, terms, orientation, poses=30, noise_mm=0.05):
    """A tracker-frame session, its first 10 poses from 0.6 times the joint ranges."""
    rng = np.random.default_rng(seed)
    robot = robots.get("ur10e")
    delta = simulate.random_errors(robot.mdh, rng, mm=0.3, rad=0.003)
    delta[:, kinematics.BETA] = 0.0
    tool = frames.transform(translation=[30.0, -20.0, 100.0])
    guess = frames.transform(translation=tool[:3, 3] + rng.normal(0.0, 1.0, 3))
    base = frames.transform(rotations.rotvec_to_matrix(rng.uniform(-1, 1, 3)), [2500, 300, 200])
    q = simulate.sample_joints(np.clip(robot.joint_limits_rad, -np.pi, np.pi), poses, rng)
    q[:10] *= 0.6
    masses = robot_masses.get("ur10e")
    tau = joint_terms.gravity_torques(robot.mdh, q, masses, 5.0, [0.0, 0.0, 100.0])
    pose = kinematics.forward(
        robot.mdh + delta, joint_terms.effective(q, terms.vector(), tau), tool, base
    )
    points = pose[:, :3, 3] + rng.normal(0.0, noise_mm / np.sqrt(3), (poses, 3))
    rotvecs = None
    if orientation:
        tilt = rotations.rotvec_to_matrix(rng.normal(0.0, 2e-5 / np.sqrt(3), (poses, 3)))
        rotvecs = rotations.matrix_to_rotvec(tilt @ pose[:, :3, :3])
    meta = session.SessionMeta(
        frame="tracker", nominal_mdh=robot.mdh, model=robot.name, flange2tool=guess,
        tool_known=False,
    )  # fmt: skip
    return session.Session(session.to_table(q, points, rotvecs=rotvecs), meta)


def _predicted_and_observed(seed, terms, orientation):
    full = _session(seed, terms, orientation)
    first = session.Session(full.table.slice(0, 10), full.meta)
    result = pipeline.identify(
        first, pipeline.Options(method="lm", validation_fraction=0.0, noise_mm=0.05)
    )
    rest = full.observations.subset(np.arange(10, 30))
    # What identify predicts for held-out poses: analyse with them, and what it left out.
    left = [d["name"] for d in result.dropped if "with these poses" in d["reason"]]
    unc = uncertainty.analyse(
        Problem.of(result.space, first.observations, result.k), result.x, rest, left
    )
    position, _ = measurement.errors(result.space, result.x, rest)
    observed = float(np.linalg.norm(position, axis=1).mean())
    return unc["predicted_validation_mm"]["error_mean"], observed, len(left)


@pytest.mark.parametrize("orientation", [False, True], ids=["position-only", "6-DoF"])
@pytest.mark.parametrize("terms", [GEOMETRIC, COMPLIANT], ids=["geometric", "compliant"])
def test_first_10_in_a_narrow_range_predict_the_last_20_within_20_percent(terms, orientation):
    runs = np.array([_predicted_and_observed(seed, terms, orientation) for seed in range(16)])
    ratio = runs[:, 0].mean() / runs[:, 1].mean()
    assert 0.8 <= ratio <= 1.2, (ratio, runs)
    if not orientation:
        assert runs[:, 2].mean() > 1  # position-only: joint parameters were left out


def test_nothing_left_out_adds_nothing():
    full = _session(3, GEOMETRIC, False)
    result = pipeline.identify(
        full, pipeline.Options(method="lm", validation_fraction=0.0, noise_mm=0.05)
    )
    problem = Problem.of(result.space, full.observations, result.k)
    se = result.uncertainty["standard_errors"]
    obs = full.observations.subset(np.arange(5))
    assert not uncertainty.unidentified_variance(problem, result.x, se, obs, []).any()
    # A parameter redundant with free ones at any pose (d6 with the tool) projects out.
    (var,) = [uncertainty.unidentified_variance(problem, result.x, se, obs, ["d6"])]
    assert var.max() < 1e-12
