"""The same driver over ``rfc2217://``: an RFC 2217 server (pyserial's PortManager) in front of
the simulator's pty, as a serial-device server would sit in front of a real tracker."""

from __future__ import annotations

import numpy as np
import pytest
from tracker_kit import Rfc2217Bridge, live_tracker

from drivers.tracker import measure_average

# pyserial's own rfc2217 client still calls Thread.setDaemon/setName.
pytestmark = pytest.mark.filterwarnings(r"ignore:set(Daemon|Name)\(\) is deprecated")


@pytest.fixture
def rfc2217_url(served):
    sim, path, _ = served
    bridge = Rfc2217Bridge(path)
    yield sim, f"rfc2217://127.0.0.1:{bridge.port}"
    bridge.close()


def test_driver_over_rfc2217(rfc2217_url):
    sim, url = rfc2217_url
    with live_tracker(url) as tracker:
        status = tracker.connect()
        identity = tracker.identity
        assert identity.serial == "SIM-0001" and status.state == "READY"
        avg = measure_average(tracker, 10)
    assert avg.count == 10
    np.testing.assert_allclose(avg.mean_mm, sim._target, atol=0.03)
