"""The emScon simulator process streams a path set over its control port (``SIM,PATH``),
with ``--latency``: the driver's stream over TCP sees the path at each stamp less the latency,
and a beam break armed over the control port is marked. Bounded by the driver's deadlines,
the stream's stall timeout and the process helper's own stop timeout."""

from __future__ import annotations

import numpy as np

from drivers.tracker.emscon import open_tracker
from drivers.tracker.emscon import protocol as pk
from drivers.tracker.emscon.simulator import EmsconSimulatorProcess

LATENCY_S = 0.02
WAYPOINT_T = np.array([0.0, 0.5, 1.0])
WAYPOINTS = np.array([[2000.0, 0.0, -300.0], [2100.0, 50.0, -300.0], [2100.0, 150.0, -250.0]])


def on_path(t_us: np.ndarray, start_us: int) -> np.ndarray:
    """The path's point for stamps ``t_us`` less the latency, shape (K, 3), mm."""
    t = (np.asarray(t_us) - start_us) / 1e6 - LATENCY_S
    return np.column_stack([np.interp(t, WAYPOINT_T, c) for c in WAYPOINTS.T])


def test_the_process_streams_a_control_port_path_with_its_latency_and_a_beam_break():
    with EmsconSimulatorProcess(seed=4, noise=False, initialised=True, latency_s=LATENCY_S) as sim:
        tracker = open_tracker(sim.url, timeout_s=2.0, measure_timeout_s=2.0)
        try:
            tracker.connect()
            start_us = sim.run_path(WAYPOINT_T, WAYPOINTS, delay_s=0.05)
            sim.arm_fault("SAMPLE+20 beam_break count=3")
            with tracker.stream(50, count=60, stall_timeout_s=2.0) as stream:
                rec = stream.collect(100)
            got = rec.code == 0
            np.testing.assert_allclose(
                rec.point_mm[got], on_path(rec.t_us[got], start_us), atol=1e-3
            )
            assert list(rec.code[~got]) == [pk.ResultStatus.MEASUREMENT_STATUS_NOT_READY]
            assert rec.n[~got][0] == 20 and stream.broken == 2 and stream.lost == 0
            np.testing.assert_array_equal(np.diff(rec.t_us[got][:10]), 20_000)  # 50 Hz
            # The path moves: the points span it rather than repeating one position.
            assert np.ptp(rec.point_mm[got, 0]) > 50.0
            # Stationary again after the stream: the path's end, held.
            np.testing.assert_allclose(tracker.measure().point_mm, WAYPOINTS[-1], atol=1e-3)
        finally:
            tracker.close()
