"""Averaging a pose's readings: flagged readings left out by default, half must remain."""

from dataclasses import dataclass

import numpy as np
import pytest

from calibrator.acquire.averaging import TooFewReadings, measure_average


@dataclass
class Reading:
    point_mm: np.ndarray
    accurate: bool
    rotvec_rad: np.ndarray | None = None
    device_time_us: int = 0


class ScriptedTracker:
    """Hands out prepared readings in order (the input of the averaging under test)."""

    def __init__(self, readings):
        self._readings = list(readings)

    def measure(self, timeout_s=None):
        return self._readings.pop(0)


def test_flagged_readings_are_left_out_by_default_and_half_must_remain():
    good = [Reading(np.array([1.0, 2.0, 3.0]) + 0.01 * i, True) for i in range(3)]
    flagged = [Reading(np.array([1.03, 2.03, 3.03]), False) for _ in range(2)]
    mean = measure_average(ScriptedTracker(good + flagged), 5)
    np.testing.assert_allclose(mean.mean_mm, [1.01, 2.01, 3.01])
    assert (mean.count, mean.rejected) == (3, 2)
    # Three of six accepted is the default minimum (half, rounded up); two is not.
    with pytest.raises(TooFewReadings):
        measure_average(ScriptedTracker(good[:2] + flagged * 2), 6)
    kept = measure_average(ScriptedTracker(good[:2] + flagged * 2), 6, min_count=2)
    assert kept.count == 2
    everything = measure_average(ScriptedTracker(good + flagged), 5, reject_flagged=False)
    assert everything.count == 5
