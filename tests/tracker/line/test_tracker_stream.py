"""Streaming measurement (``STREAM``): the driver against the simulator over a real pty and TCP.

Every tick is checked against the simulator's moving target at its own
stamp, so a stale point (a position from another time) cannot pass, and the
integrity rules of single readings hold for streams: numbered ticks (gaps
counted, never filled), CRC (a corrupted tick is lost, not read), beam breaks
marked where they happen, a stalled stream raised as such.
"""

from __future__ import annotations

import subprocess
import sys
import time

import numpy as np
import pytest
from tracker_kit import REPO, live_tracker

from drivers.tracker.errors import ConnectionLost, FrameError, NotInitialised, TrackerError
from drivers.tracker.line.errors import StreamStalled
from drivers.tracker.line.protocol import (
    ErrorCode,
    parse_stream_frame,
    parse_stream_rate,
    stream_body,
)
from drivers.tracker.line.simulator import NoiseModel, SimulatorServer, TrackerSimulator

START = np.array([2000.0, 300.0, -200.0])
VELOCITY = np.array([100.0, -50.0, 20.0])  # mm/s


def line_motion(t_s: float) -> np.ndarray:
    """A target moving at VELOCITY through START at device time 0."""
    return START + VELOCITY * t_s


@pytest.fixture(params=["pty", "tcp"])
def streaming(request):
    """``(sim, url)``: an exact (noise-free) simulator with a moving target, served in a thread."""
    sim = TrackerSimulator(seed=2, noise=NoiseModel(enabled=False), initialised=True)
    sim.set_motion(line_motion)
    server = SimulatorServer(sim)
    path = server.open_pty()
    port = server.open_tcp(0)
    server.start()
    yield sim, path if request.param == "pty" else f"socket://127.0.0.1:{port}"
    server.stop()


def test_stream_frames_round_trip_and_bad_ones_are_refused():
    body = stream_body(12, 3, "P3", "1.0000", "2.0000", "3.0000", "ACC", "1500")
    frame = parse_stream_frame(body)
    assert (frame.stream_id, frame.n, frame.device_time_us, frame.end) == (12, 3, 1500, False)
    np.testing.assert_array_equal(frame.reading.point_mm, [1.0, 2.0, 3.0])
    assert parse_stream_frame("SR,12,4,NONE,6,1600").code == ErrorCode.BEAM_BROKEN
    assert parse_stream_frame("SR,12,9,END,2000").end
    for bad in ("SR,0,1,END,5", "SR,1,01,END,5", "SR,1,1,NONE,0,5", "SR,1,1,P3,1,2,ACC,5"):
        with pytest.raises(FrameError):
            parse_stream_frame(bad)
    assert parse_stream_rate(("500",)) == (500, None)
    assert parse_stream_rate(("10", "7")) == (10, 7)
    for bad in (("0",), ("1001",), ("1e2",), ("10", "0"), ()):
        with pytest.raises(ValueError):
            parse_stream_rate(bad)


def test_a_counted_stream_gives_every_tick_where_the_moving_target_was_at_its_stamp(streaming):
    sim, url = streaming
    with live_tracker(url) as tracker:
        tracker.connect()
        with tracker.stream(200, count=100) as stream:
            samples = list(stream)
        assert stream.ended and stream.lost == 0 and stream.stale == 0
        # The driver works on normally afterwards.
        assert tracker.status().state == "READY"
    assert [s.n for s in samples] == list(range(1, 101))
    t = np.array([s.device_time_us for s in samples]) / 1e6
    np.testing.assert_allclose(np.diff(t), 0.005, atol=2e-6)  # stamped at their due ticks
    points = np.array([s.reading.point_mm for s in samples])
    expected = START + VELOCITY * t[:, None]
    np.testing.assert_allclose(points, expected, atol=1e-4)  # 0.1 um: the wire's resolution


def test_the_tracker_latency_shows_as_a_lag_of_the_stamped_positions(streaming):
    sim, url = streaming
    sim.latency_s = 0.015
    with live_tracker(url) as tracker:
        tracker.connect()
        with tracker.stream(100, count=20) as stream:
            rec = stream.collect(20)
    t = rec.t_us / 1e6
    np.testing.assert_allclose(rec.point_mm, START + VELOCITY * (t - 0.015)[:, None], atol=1e-4)


def test_a_beam_break_is_marked_on_its_ticks_and_the_stream_goes_on(streaming):
    sim, url = streaming
    sim.arm_fault("SAMPLE+20 beam_break count=5")
    with live_tracker(url) as tracker:
        tracker.connect()
        with tracker.stream(250, count=60) as stream:
            rec = stream.collect(60)
        events = [e.code for e in tracker.events]
    broken = np.flatnonzero(rec.code == ErrorCode.BEAM_BROKEN)
    np.testing.assert_array_equal(rec.n[broken], [20, 21, 22, 23, 24])
    assert np.all(np.isnan(rec.point_mm[broken]))  # no position made up for them
    assert np.all(np.isfinite(np.delete(rec.point_mm, broken, axis=0)))
    np.testing.assert_array_equal(rec.n, np.arange(1, 61))  # nothing lost around the break
    assert events == [ErrorCode.BEAM_BROKEN, ErrorCode.BEAM_RESTORED]


def test_a_corrupted_or_dropped_tick_is_a_counted_gap_never_a_reading(streaming):
    sim, url = streaming
    sim.arm_fault("SAMPLE+5 bad_crc")
    sim.arm_fault("SAMPLE+9 garble")
    sim.arm_fault("SAMPLE+12 drop")
    with live_tracker(url) as tracker:
        tracker.connect()
        with tracker.stream(200, count=20) as stream:
            rec = stream.collect(20)
        assert stream.lost == 3
        assert tracker.link.counters.bad_stream_lines == 2
    assert sorted(set(range(1, 21)) - set(rec.n.tolist())) == [5, 9, 12]
    t = rec.t_us / 1e6
    np.testing.assert_allclose(rec.point_mm, START + VELOCITY * t[:, None], atol=1e-4)


def test_a_short_stall_loses_its_ticks_and_the_stream_resumes_in_order(streaming):
    sim, url = streaming
    sim.arm_fault("SAMPLE+10 stall delay=0.1")
    with live_tracker(url) as tracker:
        tracker.connect()
        with tracker.stream(100, count=40, stall_timeout_s=2.0) as stream:
            rec = stream.collect(40)
        lost = stream.lost
    assert np.all(np.diff(rec.n) > 0)
    # The stalled tick and the 10 due during the 0.1 s silence are missing, and counted.
    assert lost == 11 and len(rec.n) == 40 - 11
    assert rec.n[9] - rec.n[8] == 12
    t = rec.t_us / 1e6
    np.testing.assert_allclose(rec.point_mm, START + VELOCITY * t[:, None], atol=1e-4)


def test_a_stalled_stream_raises_and_is_stopped_and_the_driver_measures_again(streaming):
    sim, url = streaming
    sim.arm_fault("SAMPLE+5 stall delay=3.0")
    with live_tracker(url) as tracker:
        tracker.connect()
        started = time.monotonic()
        got = []
        with pytest.raises(StreamStalled, match="no tick within 0.3 s after tick 4"):
            with tracker.stream(100, stall_timeout_s=0.3) as stream:
                for sample in stream:
                    got.append(sample.n)
        assert time.monotonic() - started < 2.0
        assert stream.ended
        # STOP went out: a single reading works, with no late tick mistaken for it.
        before = sim.device_time_s()
        reading = tracker.measure()
        assert reading.device_time_us / 1e6 >= before
    assert got == [1, 2, 3, 4]


def test_stop_ends_an_open_stream_and_late_ticks_never_reach_the_next_stream(streaming):
    sim, url = streaming
    with live_tracker(url) as tracker:
        tracker.connect()
        with tracker.stream(500) as first:
            first.collect(25)
        # Ticks sent between our STOP and its OK were dropped by the transaction.
        with tracker.stream(500, count=10) as second:
            rec = second.collect(10)
        assert second.stream_id != first.stream_id
        np.testing.assert_array_equal(rec.n, np.arange(1, 11))
        t = rec.t_us / 1e6
        np.testing.assert_allclose(rec.point_mm, START + VELOCITY * t[:, None], atol=1e-4)


def test_stream_refusals_are_typed(streaming):
    sim, url = streaming
    with live_tracker(url) as tracker:
        tracker.connect()
        with pytest.raises(TrackerError) as bad:
            tracker.stream(5000)
        assert bad.value.code == ErrorCode.BAD_PARAMETER
        sim.initialised = False
        with pytest.raises(NotInitialised):
            tracker.stream(100)


def test_ticks_arriving_while_a_command_waits_are_dropped_not_taken_for_its_reply(streaming):
    sim, url = streaming
    with live_tracker(url) as tracker:
        tracker.connect()
        with tracker.stream(1000) as stream:
            stream.collect(5)
            time.sleep(0.05)  # ~50 ticks queue up in front of the reply
            status = tracker.status()
            assert status.state == "READY"
            dropped = tracker.link.counters.stream_frames_dropped
            assert dropped >= 20
            # The stream itself goes on after the command, in order, with the gap counted.
            after = stream.collect(5)
        assert np.all(np.diff(after.n) == 1) and after.n[0] > 5 + dropped


def test_a_connection_lost_mid_stream_ends_it_and_the_next_command_reconnects(served):
    sim, _, tcp_url = served
    sim.arm_fault("SAMPLE+5 hangup")
    with live_tracker(tcp_url) as tracker:
        tracker.connect()
        got = []
        with pytest.raises(ConnectionLost):
            with tracker.stream(200) as stream:
                for sample in stream:
                    got.append(sample.n)
        assert got == [1, 2, 3, 4] and stream.ended
        assert tracker.status().state == "READY"  # reconnected, same tracker
        np.testing.assert_allclose(tracker.measure().point_mm, [2000.0, 300.0, -200.0], atol=0.2)


def test_the_simulator_refuses_a_bad_latency_in_one_line():
    done = subprocess.run(
        [sys.executable, "-m", "drivers.tracker.line.simulator", "--pty", "--latency", "2"],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert done.returncode == 2 and done.stdout == ""
    assert done.stderr.count("\n") == 1 and "latency in 0..1 s" in done.stderr
