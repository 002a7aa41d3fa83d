"""The path test's orientation figures (ISO 9283 7.2 and 7.3: AT_a..c, RT_a..c).

From synthetic streams whose orientation deviations are known by construction,
through the path section verify writes (:func:`calibrator.verify.path.figures`);
a reflector's streams leave them None. And the simulated arm's probe
orientations, sent to the tracker simulator as waypoints, stay continuous
where the rotation vector would flip (through pi).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from calibrator.model import rotations
from calibrator.verify import iso9283
from calibrator.verify import path as verify_path
from calibrator.verify import path_figures as ip
from drivers.robot.sim.device import continuous_rotvecs

RATE_HZ = 500.0
SPEED = 200.0
#: The tool's commanded angles (a, b, c), rad: b well away from 0 so all three differ.
COMMANDED = np.array([0.3, 0.5, -0.7])


def _test(shape: str = "line") -> verify_path.PathTest:
    """A commanded path test in a 300 mm cube (its joints are not looked at here)."""
    cube = iso9283.Cube(np.array([600.0, 0.0, 500.0]), 300.0)
    rotation = rotations.rotations_xyz(COMMANDED)
    path = verify_path.test_path(shape, cube, rotation)
    t = np.linspace(0.0, path.length_mm / SPEED, 11)
    return verify_path.PathTest(shape, path, rotation, SPEED, t, np.zeros((11, 6)), False)


def _stream(test: verify_path.PathTest, abc_rad) -> ip.Stream:
    """The commanded path run exactly at SPEED, with orientation angles ``abc_rad`` (3,) or None."""
    s = np.arange(0.0, test.path.length_mm + 1e-9, SPEED / RATE_HZ)
    p = test.path.point(s)
    abc = None if abc_rad is None else np.tile(np.asarray(abc_rad, dtype=float), (len(s), 1))
    return ip.Stream(np.arange(len(s)) / RATE_HZ, p, abc)


@pytest.mark.parametrize("shape", ["line", "circle", "rectangle"])
def test_a_known_orientation_offset_and_spread_give_the_known_figures(shape):
    test = _test(shape)
    offset = np.array([0.004, -0.0025, 0.0015])  # rad, the mean attained less the commanded
    spread = np.array([0.001, 0.0, 0.002])  # rad, cycle 1 at +spread, cycle 2 at -spread
    streams = [_stream(test, COMMANDED + offset + sign * spread) for sign in (1.0, -1.0)]
    section = verify_path.figures(test, streams, [0.0, 0.0], 2)
    assert section["orientation"] == "measured (6-DoF probe)"
    for k, axis in enumerate("abc"):
        # AT = |mean deviation| at every calculated point; RT = 3 S over the two cycles,
        # S = sqrt(2) * spread for deviations offset +- spread.
        assert section[f"AT{axis}_deg"] == pytest.approx(math.degrees(abs(offset[k])), rel=1e-9)
        assert section[f"RT{axis}_deg"] == pytest.approx(
            math.degrees(3.0 * math.sqrt(2.0) * spread[k]), rel=1e-9, abs=1e-12
        )
    assert section["commanded"]["abc_deg"] == pytest.approx(np.degrees(COMMANDED).tolist())
    # The position figures are untouched by the orientation: the path runs exactly (on
    # the circle but for the 0.2 um sag of a 0.4 mm chord between two samples).
    assert section["AT_P_mm"] == pytest.approx(0.0, abs=1e-3)


def test_an_orientation_that_changes_along_the_path_gives_its_largest_mean_deviation():
    test = _test("line")
    s = np.arange(0.0, test.path.length_mm + 1e-9, SPEED / RATE_HZ)
    ramp = 0.01 * s / test.path.length_mm  # c drifts from 0 to 10 mrad along the line
    abc = np.tile(COMMANDED, (len(s), 1))
    abc[:, 2] += ramp
    stream = ip.Stream(np.arange(len(s)) / RATE_HZ, test.path.point(s), abc)
    section = verify_path.figures(test, [stream, stream], [0.0, 0.0], 2)
    last = section["points"]["s_mm"][-1]  # the calculated point nearest the end
    assert section["ATc_deg"] == pytest.approx(math.degrees(0.01 * last / test.path.length_mm))
    assert section["ATa_deg"] == pytest.approx(0.0, abs=1e-9)
    assert section["RTc_deg"] == pytest.approx(0.0, abs=1e-9)


def test_a_reflector_stream_leaves_the_orientation_figures_none():
    test = _test("line")
    section = verify_path.figures(test, [_stream(test, None)] * 2, [0.0, 0.0], 2)
    assert section["orientation"].startswith("not measured")
    for name in verify_path.ORIENTATION_FIGURES:
        assert name in section and section[name] is None


def test_probe_orientations_turning_through_pi_stay_continuous_and_unchanged():
    # The tool turns about a fixed axis from 170 to 190 degrees: matrix_to_rotvec keeps
    # the angle in [0, pi], so its vector flips to the other side at 180 degrees.
    axis = np.array([1.0, 2.0, -2.0]) / 3.0
    angle = np.radians(np.linspace(170.0, 190.0, 201))
    matrices = rotations.rotvec_to_matrix(angle[:, None] * axis)
    raw = rotations.matrix_to_rotvec(matrices)
    assert np.linalg.norm(np.diff(raw, axis=0), axis=1).max() > 6.0  # the flip
    smooth = continuous_rotvecs(raw)
    step = np.linalg.norm(np.diff(smooth, axis=0), axis=1)
    assert step.max() < 2.0 * np.radians(0.1)  # 0.1 degree a sample, no jump
    assert rotations.rotvec_to_matrix(smooth) == pytest.approx(matrices, abs=1e-12)
    # A path far from pi is left exactly as it was.
    calm = raw[:5] * 0.1
    assert np.array_equal(continuous_rotvecs(calm), calm)
