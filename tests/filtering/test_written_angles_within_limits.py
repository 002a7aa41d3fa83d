"""Angles a program states are rounded inward: read back, a target at a limit is never past it.

A plan pose at a joint limit written to 6 decimals of a degree may round
past the limit, and a controller refuses the whole program. The writer
rounds such an angle toward the inside instead, also for a joint the
controller counts relative to another (Fanuc's J3 with J2): its limit in
the controller's angle is then shifted by the other joint's written angle,
and read back through the coupling the angle lands within the limit and
within 1e-6 deg of the plan.
"""

from __future__ import annotations

import numpy as np
import pytest

from calibrator import robots
from calibrator.languages.spec import ProgramSpec


def _spec(limits, convention=None):
    return ProgramSpec(
        plan_rad=np.zeros((1, 6)), home_rad=np.zeros(6), speed_rad_s=0.5, accel_rad_s2=1.0,
        max_joint_speed_rad_s=np.full(6, 3.0), joint_limits_rad=limits, convention=convention,
    )  # fmt: skip


def test_an_angle_at_a_limit_that_would_round_past_it_is_rounded_inward():
    limits = np.tile([-np.pi, np.pi], (6, 1))
    limits[0] = np.radians([-100.0000006, 100.0000006])  # to nearest: 100.000001, past it
    spec = _spec(limits)
    assert spec.angles(np.array([limits[0, 1], 0, 0, 0, 0, 0]), "deg")[0] == "100.000000"
    assert spec.angles(np.array([limits[0, 0], 0, 0, 0, 0, 0]), "deg")[0] == "-100.000000"
    # Inside the limits, to nearest.
    assert spec.angles(np.radians([99.9999996, 0, 0, 0, 0, 0]), "deg")[0] == "100.000000"
    assert spec.angles(np.radians([12.3456785, 0, 0, 0, 0, 0]), "deg")[0] == "12.345678"


@pytest.mark.parametrize("j2", [-0.5, 0.5])
@pytest.mark.parametrize("end", [0, 1])
def test_a_coupled_joint_at_its_limit_reads_back_within_it(j2, end):
    arm = robots.get("fanuc-m20ia")
    conv, limits = arm.convention, arm.joint_limits_rad
    assert conv.couplings  # J3 counted with J2
    q = np.array([0.0, j2, limits[2, end], 0.0, 0.3, 0.0])
    texts = _spec(limits, conv).angles(q, "deg")
    back = conv.to_model(np.radians(np.array(texts, dtype=float)))
    assert limits[2, 0] <= back[2] <= limits[2, 1]
    np.testing.assert_allclose(np.degrees(back), np.degrees(q), atol=1e-6)
