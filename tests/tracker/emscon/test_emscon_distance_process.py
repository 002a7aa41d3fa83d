"""The emScon simulator process in 6-DoF continuous distance mode: a probe path set over the
control port (``SIM,PATH`` with orientations) streamed over TCP, with ``--latency`` and a
beam break armed over the control port. Bounded by the driver's deadlines, the stream's
stall timeout and the process helper's own stop timeout."""

from __future__ import annotations

import numpy as np

from drivers.tracker.emscon import open_tracker
from drivers.tracker.emscon import protocol as pk
from drivers.tracker.emscon.simulator import EmsconSimulatorProcess

LATENCY_S = 0.01
STEP_MM = 5.0
WAYPOINT_T = np.array([0.0, 0.5, 1.0])
WAYPOINTS = np.array([[2000.0, 0.0, -300.0], [2100.0, 50.0, -300.0], [2100.0, 150.0, -250.0]])
ROTVECS = np.array([[0.0, 0.0, 0.2], [0.1, 0.0, 0.4], [0.1, -0.2, 0.4]])


def on_path(t_us: np.ndarray, start_us: int, values: np.ndarray) -> np.ndarray:
    """The path's ``values`` (waypoints or orientations) at stamps ``t_us`` less the latency."""
    t = (np.asarray(t_us) - start_us) / 1e6 - LATENCY_S
    return np.column_stack([np.interp(t, WAYPOINT_T, c) for c in values.T])


def test_a_probe_path_streams_in_6dof_distance_mode_with_its_latency_and_a_beam_break():
    with EmsconSimulatorProcess(
        seed=4, noise=False, initialised=True, probe=True, latency_s=LATENCY_S
    ) as sim:
        tracker = open_tracker(sim.url, timeout_s=2.0, measure_timeout_s=2.0)
        try:
            tracker.connect()
            start_us = sim.run_path(WAYPOINT_T, WAYPOINTS, ROTVECS, delay_s=0.05)
            sim.arm_fault("SAMPLE+200 beam_break count=30")  # 30 ms blind, 0.2 s in
            with tracker.stream(distance_mm=STEP_MM, count=30, stall_timeout_s=2.0) as stream:
                rec = stream.collect(100)
            assert stream.six_dof  # the server reports its probe
            got = rec.code == 0
            assert int(got.sum()) == 30 and stream.bad == 0 and stream.stale == 0
            assert list(rec.code[~got]) == [pk.ResultStatus.MEASUREMENT_STATUS_NOT_READY]
            np.testing.assert_allclose(
                rec.point_mm[got], on_path(rec.t_us[got], start_us, WAYPOINTS), atol=1e-3
            )
            assert rec.rotvec_rad is not None
            np.testing.assert_allclose(
                rec.rotvec_rad[got], on_path(rec.t_us[got], start_us, ROTVECS), atol=1e-5
            )
            # Points at least STEP_MM apart (once the path moves: the first is where the
            # target waits for the path's start): a 1 ms check's travel (0.22 mm) more at
            # most, except across the break: 30 ms blind at 224 mm/s is 6.7 mm of travel.
            steps = np.linalg.norm(np.diff(rec.point_mm[got], axis=0), axis=1)[1:]
            assert np.all(steps >= STEP_MM - 1e-9)
            (mark,) = np.flatnonzero(~got)
            across = np.linalg.norm(rec.point_mm[mark + 1] - rec.point_mm[mark - 1])
            assert across > 0.9 * 30 * 0.224 and across > STEP_MM + 1.0
            assert np.all(np.delete(steps, mark - 2) < STEP_MM + 0.3)
            # Stationary again after the stream: a 6-DoF reading where the probe now is.
            reading = tracker.measure()
            assert reading.rotvec_rad is not None and reading.point_mm.shape == (3,)
        finally:
            tracker.close()
