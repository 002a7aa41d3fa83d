"""The outlier test's false alarms on clean data, and its power on a real outlier.

Clean sessions carry the tracker simulator's noise (anisotropic: the beam
axis is several times quieter than the transverse ones, and the noise grows
with range), averaged over 10 readings per pose, as ``measure`` records it.
"""

import numpy as np
import pytest
from cli_testkit import cli

from calibrator import measurement, parameters
from calibrator.identify import refine, robust
from calibrator.identify.problem import Problem
from calibrator.models import get_model
from calibrator.simulate import NoiseModel

NAMES = ("a2", "alpha2", "d3", "a3", "d4", "theta5", "base_tx", "base_ty", "base_rz")
TRACKER_AT = np.array([2600.0, 900.0, 300.0])  # mm, base frame; axes aligned with the base
NOISE = NoiseModel()


def session(n, rng, outlier_mm=0.0):
    """A clean (or one-outlier) UR10e session: joints, points; truth deltas."""
    space = parameters.ParameterSpace(get_model("ur10e").mdh, free=NAMES)
    q = rng.uniform(-2.0, 2.0, (n, 6))
    x = rng.normal(0, 0.02, len(NAMES))
    points = measurement.predict(space, x, q)[:, :3, 3]
    # 10 readings averaged: a tenth of one reading's variance, along the beam and across it.
    for i, p in enumerate(points):
        points[i] += rng.standard_normal(3) @ NOISE.scale_matrix(p - TRACKER_AT) / np.sqrt(10)
    if outlier_mm:
        direction = rng.standard_normal(3)
        points[n // 2] += outlier_mm * direction / np.linalg.norm(direction)
    return space, measurement.Observations(q, points, None)


def named(space, obs):
    problem = Problem.of(space, obs, 0.0)
    x = refine.refine(problem, np.zeros(space.size)).x
    beams = robust.beam_axes(obs.points - TRACKER_AT)
    return robust.outliers(
        problem.residuals(x), len(obs), jacobian=problem.jacobian(x), beams=beams
    )


@pytest.mark.parametrize(("poses", "sessions"), [(16, 120), (40, 120), (200, 40)])
def test_clean_sessions_of_any_size_rarely_warn(poses, sessions):
    rng = np.random.default_rng(poses)
    warned = sum(len(named(*session(poses, rng))) > 0 for _ in range(sessions))
    assert warned <= 0.05 * sessions, f"{warned} of {sessions} clean {poses}-pose sessions warned"


@pytest.mark.parametrize("poses", [16, 40, 200])
def test_a_real_outlier_is_still_named(poses):
    rng = np.random.default_rng(100 + poses)
    hits = 0
    for _ in range(10):
        space, obs = session(poses, rng, outlier_mm=0.1)  # about 12 transverse sigmas
        hits += (poses // 2) in named(space, obs).tolist()
    assert hits >= 9


def test_measure_then_identify_on_20_seeds_warns_at_most_once(tmp_path):
    """``measure`` (the tracker simulator's noise, over its pty) then ``identify``.

    One 40-pose plan is shared by the 20 seeds (planning is most of a
    ``measure --poses 40`` run); the seed draws each simulated arm's errors,
    its tool and the tracker's noise.
    """
    made = cli(
        "plan", "--poses", 40, "--tracker-at", "2500,400,300", "-o", "plan.csv", cwd=tmp_path
    )
    assert made.code == 0, made.stderr
    warned = []
    for seed in range(20):
        run = cli(
            "measure",
            "--plan",
            "plan.csv",
            "--seed",
            seed,
            "-q",
            "-o",
            f"s{seed}.parquet",
            cwd=tmp_path,
        )
        assert run.code == 0, run.stderr
        fit = cli("identify", f"s{seed}.parquet", "-o", f"c{seed}.json", cwd=tmp_path)
        assert fit.code == 0, fit.stderr
        assert "residual sigma" in fit.stdout  # the fit ran to its report
        if "possible outliers" in fit.stdout + fit.stderr:
            warned.append(seed)
    assert len(warned) <= 1, f"clean sessions warned about outliers: seeds {warned}"
