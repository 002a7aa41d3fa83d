"""Stop detection: noise never vetoes a stop, creep and ringing never make one."""

import numpy as np

from calibrator.acquire.external import StopDetector

RATE_HZ = 50.0
SIGMA_MM = 0.016  # per axis: the simulator's transverse noise at 3 m


def _feed(detector, points, t0=0.0):
    """Times (s) at which a stop was taken while feeding ``points`` (M, 3) at 50 Hz."""
    stops = []
    for k, p in enumerate(points):
        t = t0 + k / RATE_HZ
        if detector.add(t, p) is not None:
            stops.append(t - t0)
    return stops


def _still(seconds, at=(2000.0, 300.0, 100.0), seed=0):
    rng = np.random.default_rng(seed)
    n = int(seconds * RATE_HZ)
    return np.asarray(at) + rng.normal(0.0, SIGMA_MM, (n, 3))


def test_a_still_target_with_tracker_noise_is_one_stop_after_the_window():
    for seed in range(20):
        stops = _feed(StopDetector(0.05, 0.5), _still(3.0, seed=seed))
        assert len(stops) == 1, seed  # one dwell, one stop, however long
        assert 0.5 <= stops[0] <= 0.6


def test_a_creeping_arm_is_never_stopped():
    t = np.arange(0, 4.0, 1 / RATE_HZ)
    creep = _still(4.0) + np.outer(t, [0.3, 0.0, 0.0])  # 0.3 mm/s: 0.15 mm per window
    assert _feed(StopDetector(0.05, 0.5), creep) == []


def test_ringing_delays_the_stop_until_it_has_died_down():
    t = np.arange(0, 3.0, 1 / RATE_HZ)
    ring = 0.5 * np.exp(-t / 0.3) * np.cos(2 * np.pi * 6 * t)  # mm
    points = _still(3.0) + np.outer(ring, [0.0, 1.0, 0.0])
    stops = _feed(StopDetector(0.05, 0.5), points)
    assert len(stops) == 1
    # amplitude below the band only after ~0.7 s; a window later the stop
    assert stops[0] > 0.9


def test_a_lost_reading_restarts_the_window_and_rearms():
    detector = StopDetector(0.05, 0.5)
    assert len(_feed(detector, _still(1.0))) == 1
    detector.lost()  # beam broken: the arm may have gone anywhere and come back
    assert len(_feed(detector, _still(1.0), t0=10.0)) == 1


def test_a_new_stop_needs_the_target_to_move_away_first():
    detector = StopDetector(0.05, 0.5)
    first = _still(1.0)
    second = _still(1.0, at=(2000.0, 300.0, 100.3), seed=1)  # 0.3 mm away: same stop
    third = _still(1.0, at=(2100.0, 300.0, 100.0), seed=2)  # 100 mm away: a new stop
    assert len(_feed(detector, first)) == 1
    assert _feed(detector, second, t0=1.0) == []
    assert len(_feed(detector, third, t0=2.0)) == 1
