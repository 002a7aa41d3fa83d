"""The watching's clock: the tracker's stamps, its rate, the host's clock where stamps stop."""

import numpy as np
import pytest

from calibrator.acquire.external import StopDetector
from calibrator.acquire.external.clock import RATE_SPAN_S, TrackerClock


class Host:
    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


def test_stamps_keep_their_own_spacing_however_late_they_arrive():
    host = Host()
    clock = TrackerClock(host)
    rng = np.random.default_rng(0)
    stamps_us = 5_000_000 + np.arange(50) * 20_000  # a reading every 20 ms of the tracker
    times = []
    for stamp in stamps_us:
        host.t += 0.02 + rng.uniform(-0.015, 0.015)  # a busy host picks them up unevenly
        times.append(clock.stamp(int(stamp)))
    np.testing.assert_allclose(np.diff(times), 0.02, atol=1e-9)


def test_a_stop_is_taken_a_window_of_the_tracker_after_the_arm_stood_still():
    """50 Hz readings of a still target, the host stalling 0.3 s after the tenth: the stop
    comes 0.5 s of the tracker after the first reading, not 0.5 s of the host's clock."""
    host = Host()
    clock = TrackerClock(host)
    detector = StopDetector(0.05, 0.5)
    point = np.array([2000.0, 300.0, 100.0])
    times, stops = [], []
    for k in range(40):
        host.t += 0.3 if k == 10 else 0.001
        times.append(clock.stamp(k * 20_000))
        if detector.add(times[-1], point) is not None:
            stops.append(k)
    assert stops == [25]  # 25 readings of 20 ms: the window
    assert times[25] - times[0] == pytest.approx(0.5)


def test_a_tracker_ten_times_faster_than_the_host_sets_the_pace():
    host = Host()
    clock = TrackerClock(host)
    for k in range(100):  # a reading every 2 ms of the host, 20 ms apart in stamps
        host.t += 0.002
        clock.stamp(k * 20_000)
    assert 100 * 0.002 > RATE_SPAN_S
    assert clock.rate == pytest.approx(10.0, rel=1e-6)
    assert clock.host_seconds(0.02) == pytest.approx(0.002)
    before = clock.now()
    host.t += 0.1  # no reading for 0.1 s of the host (a lost beam): 1 s of the tracker
    assert clock.now() - before == pytest.approx(1.0)


@pytest.mark.parametrize("stamp_us", [0, 123])
def test_a_tracker_whose_stamps_stand_still_is_timed_by_the_host(stamp_us):
    host = Host()
    clock = TrackerClock(host)
    times = []
    for _ in range(10):
        host.t += 0.02
        times.append(clock.stamp(stamp_us))
    np.testing.assert_allclose(np.diff(times), 0.02)
    assert clock.rate == 1.0
