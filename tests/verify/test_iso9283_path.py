"""ISO 9283 clause 7 figures from synthetic streams whose deviations are known by construction."""

from __future__ import annotations

import math

import numpy as np
import pytest

from calibrator.verify import path_figures as ip

RATE_HZ = 1000.0


def _timed(points: np.ndarray, abc: np.ndarray | None = None, t0: float = 0.0) -> ip.Stream:
    """A stream of ``points`` sampled at RATE_HZ from ``t0``."""
    return ip.Stream(t0 + np.arange(len(points)) / RATE_HZ, points, abc)


def _line_stream(path: ip.Polyline, speed: float, offset=(0.0, 0.0, 0.0)) -> ip.Stream:
    """The commanded line run at ``speed`` mm/s, shifted by ``offset`` mm."""
    s = np.arange(0.0, path.length_mm + 1e-9, speed / RATE_HZ)
    return _timed(path.point(s) + np.asarray(offset))


LINE = ip.line([400.0, -100.0, 300.0], [700.0, 200.0, 600.0])  # along a cube diagonal


def test_an_offset_line_has_path_accuracy_equal_to_the_offset_and_no_spread():
    # Offset normal to the line: (1, -1, 0)/sqrt(2) is normal to (1, 1, 1).
    offset = 0.2 * np.array([1.0, -1.0, 0.0]) / math.sqrt(2.0)
    streams = [_line_stream(LINE, 100.0, offset) for _ in range(3)]
    out = ip.path_figures(LINE, streams, m=50)
    assert out["AT_P_mm"] == pytest.approx(0.2, abs=1e-9)
    assert out["AT_i_mm"] == pytest.approx(np.full(50, 0.2), abs=1e-9)
    assert out["RT_P_mm"] == pytest.approx(0.0, abs=1e-9)


def test_an_offset_along_the_line_is_no_path_deviation():
    # The normal plane takes the crossing, not the sample at the same time.
    streams = [_line_stream(LINE, 100.0, 3.0 * np.ones(3) / math.sqrt(3.0))]
    out = ip.path_figures(LINE, streams, m=20, margin_mm=10.0)
    assert out["AT_P_mm"] == pytest.approx(0.0, abs=1e-9)


def test_cycles_spread_in_a_known_cross_give_the_hand_computed_path_repeatability():
    d = 0.05
    e1 = np.array([1.0, -1.0, 0.0]) / math.sqrt(2.0)
    e2 = np.array([1.0, 1.0, -2.0]) / math.sqrt(6.0)  # both normal to the line
    offsets = [d * e1, -d * e1, 2 * d * e2, -2 * d * e2]  # barycentre on the commanded line
    out = ip.path_figures(LINE, [_line_stream(LINE, 250.0, o) for o in offsets], m=30)
    # l_ij = d, d, 2d, 2d: lbar = 1.5 d, S_l = sqrt(1/3) d
    assert out["RT_P_mm"] == pytest.approx(1.5 * d + 3.0 * math.sqrt(1.0 / 3.0) * d, rel=1e-9)
    assert out["AT_P_mm"] == pytest.approx(0.0, abs=1e-9)


def test_an_elliptical_circle_gives_the_radial_deviation_of_its_polar_equation():
    radius, a_mm, b_mm = 100.0, 100.3, 99.9  # semi-axes along x and y
    path = ip.circle([500.0, 0.0, 400.0], [0.0, 0.0, 1.0], radius, [1.0, 0.0, 0.0])
    phi = np.linspace(0.0, 2.0 * np.pi, 200_001)  # 3 um steps: chord sag ~1e-8 mm
    ellipse = np.stack([a_mm * np.cos(phi), b_mm * np.sin(phi), np.zeros_like(phi)], axis=1)
    stream = _timed(path.centre_mm + ellipse)
    m = 72
    out = ip.path_figures(path, [stream, stream], m=m)
    theta = out["s_mm"] / radius  # the calculated points' polar angles
    r = 1.0 / np.sqrt((np.cos(theta) / a_mm) ** 2 + (np.sin(theta) / b_mm) ** 2)
    assert out["AT_i_mm"] == pytest.approx(np.abs(r - radius), abs=1e-6)
    assert out["AT_P_mm"] == pytest.approx(np.abs(r - radius).max(), abs=1e-6)
    # 72 points at 2.5 + 5k degrees: the worst lies 2.5 degrees off the long axis.
    assert 0.29 < out["AT_P_mm"] < 0.3


def test_a_constant_orientation_error_gives_path_orientation_accuracy():
    stream = _line_stream(LINE, 100.0)
    k = len(stream.t_s)
    abc = np.tile([np.pi + 0.01, 0.0, -0.002], (k, 1))  # a past +pi: wrapped, not torn
    abc = np.angle(np.exp(1j * abc))
    streams = [ip.Stream(stream.t_s, stream.p_mm, abc)] * 2
    out = ip.path_figures(LINE, streams, m=10, commanded_abc_rad=[np.pi, 0.0, 0.0])
    assert out["ATa_deg"] == pytest.approx(math.degrees(0.01), rel=1e-9)
    assert out["ATc_deg"] == pytest.approx(math.degrees(0.002), rel=1e-9)
    assert out["RTa_deg"] == pytest.approx(0.0, abs=1e-9)


def test_a_cycle_that_stops_short_is_refused_naming_it():
    full = _line_stream(LINE, 100.0)
    short = _timed(full.p_mm[: len(full.t_s) // 2])
    with pytest.raises(ip.PathError, match="cycle 2 does not reach"):
        ip.path_figures(LINE, [full, short], m=10)


SQUARE = ip.rectangle([[0, 0, 0], [200, 0, 0], [200, 200, 0], [0, 200, 0]])


def _corner_stream(out_mm) -> ip.Stream:
    """Along x to the corner (200, 0, 0), then up y with outward (+x) deviation ``out_mm(s)``."""
    step = 0.01
    s1 = np.arange(0.0, 200.0, step)
    s2 = np.arange(0.0, 200.0 + step / 2, step)
    first = np.stack([s1, 0 * s1, 0 * s1], axis=1)
    second = np.stack([200.0 + out_mm(s2), s2, 0 * s2], axis=1)
    return _timed(np.vstack([first, second]))


def test_a_corner_overshoot_of_known_size_is_measured_and_no_round_off_is_seen():
    size, width = 0.35, 20.0

    def bump(s):
        return np.where(s < width, size * np.sin(np.pi * s / width), 0.0)

    out = ip.corner_figures(SQUARE, [_corner_stream(bump), _corner_stream(lambda s: 0.5 * bump(s))])
    assert out["CO_mm"][0] == pytest.approx([size, size / 2], abs=1e-9)
    assert out["CO_max_mm"][0] == pytest.approx(size, abs=1e-9)
    assert out["CR_mm"][0] == pytest.approx([0.0, 0.0], abs=1e-9)
    # The stream ends on the second corner and never comes near the third.
    assert out["CR_mm"][1] == pytest.approx([0.0, 0.0], abs=1e-9)
    assert out["CR_mm"][2] == pytest.approx([200.0, 200.0], abs=1e-9)


def test_a_rounded_corner_has_the_round_off_of_its_arc_and_no_overshoot():
    r = 5.0  # arc tangent to both segments: its closest point is r (sqrt 2 - 1) from the corner
    s1 = np.arange(0.0, 195.0, 0.01)
    arc = np.linspace(-np.pi / 2, 0.0, 20_001)
    s2 = np.arange(5.0, 200.0, 0.01)
    pts = np.vstack(
        [
            np.stack([s1, 0 * s1, 0 * s1], axis=1),
            np.stack([195.0 + r * np.cos(arc), r + r * np.sin(arc), 0 * arc], axis=1),
            np.stack([200.0 + 0 * s2, s2, 0 * s2], axis=1),
        ]
    )
    out = ip.corner_figures(SQUARE, [_timed(pts)])
    assert out["CR_mm"][0, 0] == pytest.approx(r * (math.sqrt(2.0) - 1.0), abs=1e-6)
    assert out["CO_mm"][0, 0] == pytest.approx(0.0, abs=1e-9)


def _rippled_line(v0: float, ripple: float, hz: float) -> ip.Stream:
    """LINE run with path speed ``v0 (1 + ripple sin(2 pi hz t))`` for a whole number of periods."""
    duration = LINE.length_mm / v0
    t = np.arange(0.0, duration + 0.5 / RATE_HZ, 1.0 / RATE_HZ)
    w = 2.0 * np.pi * hz
    s = v0 * t + v0 * ripple / w * (1.0 - np.cos(w * t))
    return ip.Stream(t, LINE.point(np.clip(s, 0.0, LINE.length_mm)))


def test_a_speed_ripple_gives_its_peak_to_peak_as_fluctuation_and_the_mean_as_accuracy():
    # LINE is 519.6 mm: at 103.92 mm/s it takes 5 s, 25 periods at 5 Hz.
    v0 = LINE.length_mm / 5.0
    out = ip.velocity_figures(LINE, [_rippled_line(v0, 0.02, 5.0)], v_c_mm_s=100.0)
    assert out["AV_pct"] == pytest.approx((v0 - 100.0), rel=1e-6)  # v_c = 100: % = mm/s
    # Finite differences over 1 ms see the ripple's amplitude times sinc(w dt / 2).
    assert out["FV_mm_s"] == pytest.approx(2 * 0.02 * v0, rel=1e-3)
    assert math.isnan(out["RV_pct"])


def test_cycles_at_known_mean_speeds_give_the_velocity_repeatability():
    speeds = np.array([100.0, 101.0, 99.5]) * LINE.length_mm / 500.0  # each a whole ms count
    streams = [_rippled_line(v, 0.0, 1.0) for v in speeds]
    out = ip.velocity_figures(LINE, streams, v_c_mm_s=100.0)
    assert out["vbar_mm_s"] == pytest.approx(speeds, rel=1e-6)
    assert out["RV_pct"] == pytest.approx(3.0 * speeds.std(ddof=1), rel=1e-6)
    assert out["AV_pct"] == pytest.approx(speeds.mean() - 100.0, rel=1e-5)


def test_a_known_latency_between_robot_and_tracker_streams_is_recovered():
    rng = np.random.default_rng(4)
    path = ip.circle([600.0, 0.0, 500.0], [1.0, 1.0, 1.0], 80.0, [1.0, -1.0, 0.0])
    speed, latency = 150.0, 0.0123

    def truth(t):  # where the target is at robot time t
        return path.point(np.clip(speed * (t - 0.1), 0.0, path.length_mm))

    t_robot = np.arange(0.0, 4.0, 1 / 500.0)  # UR RTDE rate
    robot = ip.stream_reference(t_robot, truth(t_robot))
    t_trk = np.arange(0.0213, 4.0, 1 / 1000.0)  # its own clock and phase
    p_trk = truth(t_trk - latency) + rng.normal(0.0, 0.005, (len(t_trk), 3))
    tau = ip.estimate_latency(t_trk, p_trk, robot, max_latency_s=0.1)
    assert tau == pytest.approx(latency, abs=5e-5)


def test_a_tracker_only_stream_is_aligned_to_the_commanded_path_timing():
    start = 0.4375  # the arm set off this late on the tracker's clock
    t = np.arange(0.0, 5.0, 1e-3)
    p = ip.commanded_reference(LINE, 120.0, t0_s=start)(t)
    tau = ip.estimate_latency(t, p, ip.commanded_reference(LINE, 120.0), max_latency_s=0.5)
    assert tau == pytest.approx(start, abs=1e-5)


def test_a_longer_speed_chord_averages_the_noise_out_of_the_fluctuation():
    rng = np.random.default_rng(9)
    clean = _rippled_line(LINE.length_mm / 5.0, 0.0, 1.0)
    noisy = ip.Stream(clean.t_s, clean.p_mm + rng.normal(0.0, 0.005, clean.p_mm.shape))
    single = ip.velocity_figures(LINE, [noisy], v_c_mm_s=100.0)["FV_mm_s"]
    chord = ip.velocity_figures(LINE, [noisy], v_c_mm_s=100.0, step=20)["FV_mm_s"]
    assert single > 20.0  # 5 um over 1 ms: noise alone
    assert chord < single / 10.0
