"""Continuous time mode: the emScon driver's stream against the simulator over loopback TCP.

Every point is checked against the simulator's moving target at its own
stamp (less the modelled latency), so a stale point (a position from
another time) cannot pass. The integrity rules are those of the line
protocol's stream: ticks numbered (here from the stamps: emScon has no
sequence number), gaps counted and never filled, a repeated or older record
dropped, a beam break marked where it happens with emScon's status, a
stalled stream raised within its timeout. Every wait is bounded: the
driver's deadlines (1 s), each stream's stall timeout, and the server's
``stop`` (joins its threads for at most 5 s).
"""

from __future__ import annotations

import time

import numpy as np
import pytest
from emscon_kit import ENV

from drivers.tracker.emscon import EmsconTracker
from drivers.tracker.emscon import protocol as pk
from drivers.tracker.emscon.errors import ConnectionLost, NotInitialised
from drivers.tracker.emscon.simulator import EmsconServer, EmsconSimulator
from drivers.tracker.instrument import NoiseModel
from drivers.tracker.line.errors import StreamStalled
from drivers.tracker.line.simulator.engine import Send

START = np.array([2000.0, 300.0, -200.0])
VELOCITY = np.array([100.0, -50.0, 20.0])  # mm/s
LATENCY_S = 0.004


def line_motion(t_s: float) -> np.ndarray:
    """A target moving at VELOCITY through START at device time 0 (mm, tracker frame)."""
    return START + VELOCITY * t_s


def truth(t_us: np.ndarray, latency_s: float = LATENCY_S) -> np.ndarray:
    """Where the target was for points stamped ``t_us`` (shape (K,) -> (K, 3), mm)."""
    return START + VELOCITY * (np.asarray(t_us)[:, None] / 1e6 - latency_s)


def _serve(sim: EmsconSimulator):
    server = EmsconServer(sim)
    server.open()
    return server.start()


def _tracker(port: int) -> EmsconTracker:
    trk = EmsconTracker(
        "127.0.0.1",
        port,
        environment=ENV,
        timeout_s=1.0,
        measure_timeout_s=1.0,
        reconnect_delay_s=0.01,
        search_after_beam_break=False,
    )
    trk.connect()
    return trk


@pytest.fixture
def moving():
    """``(sim, tracker)``: an exact simulator with a moving target and latency, served on TCP."""
    sim = EmsconSimulator(
        seed=3, initialised=True, noise=NoiseModel(enabled=False), latency_s=LATENCY_S
    )
    sim.set_motion(line_motion)
    server = _serve(sim)
    trk = _tracker(server.port)
    yield sim, trk
    trk.close()
    server.stop()


# ---------------------------------------------------------------- packets


def test_continuous_packets_have_the_header_layouts():
    # ContinuousTimeModeDataT is 4 four-byte fields: the command is 12 + 16 bytes.
    params = pk.continuous_time_params(20, 500)
    assert len(params) == 16 and pk.parse_continuous_time(params) == (20, 500)
    command = pk.encode_command(pk.Command.SET_CONTINUOUS_TIME_MODE_PARAMS, params)
    assert pk.decode_client_packet(command) == (30, params)
    # ContinuousDistanceModeDataT: a double then 3 four-byte fields.
    assert len(pk.continuous_distance_params(5.0, 0)) == 20
    # MultiMeasResultT: 48-byte head, 36-byte MeasValueT records; stamps as s + us.
    packet = pk.encode_multi_meas_result(
        [(0, 1_234_567, (1.0, 2.0, 3.0)), (1, 1_244_567, (4.0, 5.0, 6.0))], (20.0, 1013.0, 50.0)
    )
    assert len(packet) == 48 + 2 * 36
    result = pk.decode_server_packet(packet)
    assert isinstance(result, pk.MultiMeasResult)
    assert result.meas_mode == pk.MM_CONTINUOUS_TIME and result.meteo == (20.0, 1013.0, 50.0)
    assert [r.time_us for r in result.records] == [1_234_567, 1_244_567]
    assert (result.records[0].time1, result.records[0].time2) == (1, 234_567)
    assert result.records[1].values == (4.0, 5.0, 6.0) and result.records[1].status == 1


# ---------------------------------------------------------------- streaming


def test_a_moving_target_streams_at_the_requested_rate_with_its_latency(moving):
    sim, trk = moving
    t0 = time.monotonic()
    with trk.stream(100, count=40, stall_timeout_s=2.0) as stream:
        rec = stream.collect(100)
    elapsed = time.monotonic() - t0
    assert stream.separation_ms == 10 and sim.continuous_time == (10, 40)
    np.testing.assert_array_equal(rec.n, np.arange(1, 41))
    assert (stream.lost, stream.stale, stream.broken, stream.bad) == (0, 0, 0, 0)
    # Ticks are regular on the tracker's clock: 10 ms apart exactly.
    np.testing.assert_array_equal(np.diff(rec.t_us), 10_000)
    # Each point is where the target was at its stamp less the latency (not now, not
    # the previous tick: 4 ms at 112 mm/s is 0.45 mm, far above the 1e-9 here).
    np.testing.assert_allclose(rec.point_mm, truth(rec.t_us), atol=1e-9)
    assert np.linalg.norm(rec.point_mm - truth(rec.t_us, 0.0), axis=1).min() > 0.44
    assert rec.accurate.all() and (rec.code == 0).all()
    assert 0.35 < elapsed < 2.0  # 40 ticks at 100 Hz: 0.4 s of stream
    assert sim.meas_mode == pk.MM_STATIONARY  # leaving the block stopped it


def test_a_beam_break_is_marked_with_emscons_status_and_never_a_stale_point(moving):
    sim, trk = moving
    sim.arm_fault("SAMPLE+10 beam_break count=5")  # ticks 10..14 without a point
    with trk.stream(100, count=30, stall_timeout_s=2.0) as stream:
        samples = list(stream)
    marks = [s for s in samples if s.reading is None]
    assert len(marks) == 1
    mark = marks[0]
    assert mark.n == 10 and mark.beam_broken
    assert mark.code == pk.ResultStatus.MEASUREMENT_STATUS_NOT_READY
    assert mark.device_time_us == samples[8].device_time_us + 10_000  # the tick it hit
    points = [s for s in samples if s.reading is not None]
    assert [s.n for s in points] == [*range(1, 10), *range(15, 31)]
    assert stream.broken == 4 and stream.lost == 0  # the break's ticks are not "lost"
    t_us = np.array([s.device_time_us for s in points])
    got = np.array([s.reading.point_mm for s in points])
    np.testing.assert_allclose(got, truth(t_us), atol=1e-9)
    changes = [e.change for e in trk.events]
    assert pk.StatusChange.MEAS_STATUS_NOT_READY in changes
    assert pk.StatusChange.MEAS_STATUS_READY in changes


def test_a_dropped_tick_is_a_counted_gap_not_a_filled_one(moving):
    sim, trk = moving
    sim.arm_fault("SAMPLE+7 drop")
    with trk.stream(200, count=20, stall_timeout_s=2.0) as stream:
        rec = stream.collect(100)
    assert 7 not in rec.n and len(rec.n) == 19 and stream.lost == 1
    np.testing.assert_allclose(rec.point_mm, truth(rec.t_us), atol=1e-9)


def test_a_stalled_stream_raises_within_its_timeout_and_the_tracker_measures_again(moving):
    sim, trk = moving
    sim.arm_fault("SAMPLE+5 stall delay=3.0")  # silent for 3 s after tick 4
    stall_timeout_s = 0.3
    with pytest.raises(StreamStalled, match="no result within 0.3 s after tick 4"):
        with trk.stream(100, stall_timeout_s=stall_timeout_s) as stream:
            t_last = time.monotonic()
            for _ in stream:
                t_last = time.monotonic()
    waited = time.monotonic() - t_last
    assert stall_timeout_s <= waited < stall_timeout_s + 0.7
    assert stream.ended and sim.meas_mode == pk.MM_STATIONARY  # StopMeasurement was sent
    reading = trk.measure()
    np.testing.assert_allclose(
        reading.point_mm, line_motion(sim.device_time_s() - LATENCY_S), atol=0.5
    )


def test_stop_then_a_single_measurement_works_again(moving):
    sim, trk = moving
    with trk.stream(100, stall_timeout_s=2.0) as stream:  # until stopped
        rec = stream.collect(15)
    assert len(rec.n) == 15 and stream.ended
    assert sim.meas_mode == pk.MM_STATIONARY
    sim.set_target(START)
    for _ in range(3):
        np.testing.assert_array_equal(trk.measure().point_mm, START)
    # Points the server had already sent when StopMeasurement went out were dropped,
    # never taken for the single measurement.
    assert trk._link is not None and not trk._link.broken
    with trk.stream(50, count=5, stall_timeout_s=2.0) as again:
        assert len(again.collect(10).n) == 5


def test_a_connection_lost_mid_stream_ends_it_and_the_next_command_reconnects(moving):
    sim, trk = moving
    sim.arm_fault("SAMPLE+6 hangup")
    seen = []
    with pytest.raises(ConnectionLost), trk.stream(100, stall_timeout_s=2.0) as stream:
        for sample in stream:
            seen.append(sample.n)
    assert stream.ended and seen == [1, 2, 3, 4, 5]
    sim.set_target(START)  # the reconnect sets stationary mode: a fixed target measures
    np.testing.assert_array_equal(trk.measure().point_mm, START)


class _Repeating(EmsconSimulator):
    """A server that sends every point twice and, at tick 6, the point of tick 2 again."""

    def stream_tick(self, n, stamp_s):
        out = super().stream_tick(n, stamp_s)
        if n == 2:
            self.tick2 = out
        extra = self.tick2 if n == 6 else []
        return [*out, *[o for o in out if isinstance(o, Send)], *extra]


def test_repeated_and_older_points_are_dropped_as_stale():
    sim = _Repeating(seed=3, initialised=True, noise=NoiseModel(enabled=False))
    sim.set_motion(line_motion)
    server = _serve(sim)
    try:
        with _tracker(server.port) as trk, trk.stream(100, count=10, stall_timeout_s=2.0) as st:
            rec = st.collect(100)
    finally:
        server.stop()
    np.testing.assert_array_equal(rec.n, np.arange(1, 11))
    # ticks 1..9 repeated, tick 2 sent again at 6 (the stream ends at 10, before its repeat)
    assert st.stale == 9 + 1 and st.lost == 0
    np.testing.assert_allclose(rec.point_mm, truth(rec.t_us, 0.0), atol=1e-9)


def test_a_refused_start_raises_and_leaves_stationary_mode(moving):
    sim, trk = moving
    sim.initialised = False
    with pytest.raises(NotInitialised):
        trk.stream(100)
    assert sim.meas_mode == pk.MM_STATIONARY
    with pytest.raises(ValueError, match="outside 1..1000"):
        trk.stream(0.5)
