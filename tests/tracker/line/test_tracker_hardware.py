"""Against a real tracker (or a bridge to one): ``pytest --tracker-url=socket://host:port``.

Skipped without ``--tracker-url``. Never initialises the tracker (that moves
the head): the tracker must already be initialised and locked on a target
that stays still during the test.
"""

from __future__ import annotations

import numpy as np
import pytest

from drivers.tracker import LaserTracker, measure_average


def test_real_tracker_identifies_and_measures(tracker_url):
    with LaserTracker(tracker_url, timeout_s=3.0, measure_timeout_s=10.0) as tracker:
        status = tracker.connect()
        identity = tracker.identity
        assert identity.vendor and identity.serial
        if not (status.initialised and status.beam_locked):
            pytest.skip(f"tracker not ready (status {status}); initialise and lock on first")
        avg = measure_average(tracker, 10)
    assert avg.count >= 5
    assert np.all(np.isfinite(avg.mean_mm))
    # A still target on a working tracker scatters by micrometres, not millimetres.
    assert np.all(avg.std_mm < 0.1)
