"""A stream from the simulator as a separate process, its target driven along a path.

The simulated robot hands the simulator its path as waypoints over the
control socket (``SIM,PATH``) while the driver streams over the pty; the
simulator stamps its readings ``--latency`` late, and the alignment of
:mod:`calibrator.verify.path_figures` recovers that latency from the two streams.
"""

from __future__ import annotations

import numpy as np
import pytest
from tracker_kit import live_tracker

from calibrator.verify import path_figures as ip
from drivers.tracker.line.simulator import SimulatorProcess

LATENCY_S = 0.020


def test_a_known_tracker_latency_is_recovered_from_a_streamed_circle():
    circle = ip.circle([2500.0, 200.0, -300.0], [1.0, 0.0, 0.0], 150.0, [0.0, 1.0, 0.0])
    speed = 300.0  # mm/s: the circle takes 3.1 s
    t_wp = np.arange(0.0, circle.length_mm / speed, 0.004)  # the robot's 250 Hz
    p_wp = circle.point(speed * t_wp)
    with SimulatorProcess(seed=5, initialised=True, latency_s=LATENCY_S) as sim:
        start_us = sim.run_path(t_wp, p_wp, delay_s=0.2)
        with live_tracker(sim.url) as tracker:
            tracker.connect()
            with tracker.stream(500, count=1600) as stream:
                rec = stream.collect(1600)
            assert stream.lost == 0
    assert np.all(rec.code == 0) and np.all(rec.accurate)
    robot = ip.stream_reference(start_us / 1e6 + t_wp, p_wp)
    tau = ip.estimate_latency(rec.t_us / 1e6, rec.point_mm, robot, max_latency_s=0.1)
    # 10 um noise against 300 mm/s: a few microseconds; 0.2 ms leaves room.
    assert tau == pytest.approx(LATENCY_S, abs=2e-4)
