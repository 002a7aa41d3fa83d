"""Continuous distance mode and 6-DoF continuous results: the emScon driver against the
simulator over loopback TCP.

Distance mode sends a point each time the target has moved ``dSpatialDistance``
from the last one sent, not on a clock: every point is checked against the
simulator's true target at its own stamp (less the modelled latency), the
spacing against the distance asked for, a beam break must be marked once with
emScon's status, a repeated record must be dropped as stale and a silent
stream must raise within its timeout. A 6-DoF probe's stream carries its
orientation (``ProbeContinuousResultT`` records); a reflector's has none, and
the record says so (``rotvec_rad`` None). Every wait is bounded: the driver's
deadlines (1 s), each stream's stall timeout, and the server's ``stop``.
"""

from __future__ import annotations

import time

import numpy as np
import pytest
from emscon_kit import ENV

from calibrator.model import rotations
from drivers.tracker.emscon import EmsconTracker
from drivers.tracker.emscon import protocol as pk
from drivers.tracker.emscon.errors import EmsconRefused
from drivers.tracker.emscon.simulator import EmsconServer, EmsconSimulator
from drivers.tracker.instrument import NoiseModel, Send
from drivers.tracker.line.errors import StreamStalled

START = np.array([2000.0, 300.0, -200.0])
VELOCITY = np.array([100.0, -50.0, 20.0])  # mm/s: 113.6 mm/s, 0.114 mm per 1 ms check
SPEED = float(np.linalg.norm(VELOCITY))
ROT0 = np.array([0.1, -0.2, 0.3])
SPIN = np.array([0.0, 0.0, 0.5])  # rad/s about the tracker's z
LATENCY_S = 0.004
STEP_MM = 2.0
AIR = (ENV.temperature_c, ENV.pressure_hpa, ENV.humidity_pct)


def motion(t_s: float) -> np.ndarray:
    """The probe at device time ``t_s``: position (mm) and rotation vector (rad), shape (6,)."""
    return np.concatenate([START + VELOCITY * t_s, ROT0 + SPIN * t_s])


def truth(t_us: np.ndarray) -> np.ndarray:
    """Where the target was for points stamped ``t_us`` (shape (K,) -> (K, 3), mm)."""
    return START + VELOCITY * (np.asarray(t_us)[:, None] / 1e6 - LATENCY_S)


def true_rotvec(t_us: np.ndarray) -> np.ndarray:
    return ROT0 + SPIN * (np.asarray(t_us)[:, None] / 1e6 - LATENCY_S)


def _served(sim: EmsconSimulator):
    server = EmsconServer(sim)
    server.open()
    server.start()
    trk = EmsconTracker(
        "127.0.0.1",
        server.port,
        environment=ENV,
        timeout_s=1.0,
        measure_timeout_s=1.0,
        reconnect_delay_s=0.01,
        search_after_beam_break=False,
    )
    trk.connect()
    return server, trk


def _sim(cls=EmsconSimulator, **kw) -> EmsconSimulator:
    sim = cls(seed=3, initialised=True, noise=NoiseModel(enabled=False), latency_s=LATENCY_S, **kw)
    sim.set_motion(motion)
    return sim


@pytest.fixture
def reflector():
    sim = _sim()
    server, trk = _served(sim)
    yield sim, trk
    trk.close()
    server.stop()


@pytest.fixture
def probe():
    sim = _sim(probe=True)
    server, trk = _served(sim)
    yield sim, trk
    trk.close()
    server.stop()


# ---------------------------------------------------------------- packets


def test_distance_and_6dof_continuous_packets_have_the_header_layouts():
    # ContinuousDistanceModeDataT: double dSpatialDistance, long lNumberOfPoints, ES_BOOL
    # bUseRegion, ES_RegionType regionType: 20 bytes; the command is 12 + 20.
    params = pk.continuous_distance_params(2.5, 40)
    assert len(params) == 20 and pk.parse_continuous_distance(params) == (2.5, 40)
    command = pk.encode_command(pk.Command.SET_CONTINUOUS_DISTANCE_MODE_PARAMS, params)
    assert len(command) == 32 and pk.decode_client_packet(command) == (32, params)
    # ES_MeasMode: ContinuousDistance 2, 6DContinuousTime 7, 6DContinuousDistance 8.
    assert pk.CONTINUOUS_MODES == {
        (False, False): 1,
        (True, False): 2,
        (False, True): 7,
        (True, True): 8,
    }
    # ProbeContinuousResultT: 68-byte head (ReturnDataT, 8 four-byte fields, 3 doubles)
    # then 212-byte ProbeMeasValueT records (5 four-byte fields, 24 doubles).
    q = (0.5, 0.5, -0.5, 0.5)
    packet = pk.encode_probe_continuous_result(
        [(0, 2_000_001, (1.0, 2.0, 3.0), q), (1, 2_010_001, (4.0, 5.0, 6.0), (1.0, 0, 0, 0))],
        (20.0, 1013.0, 50.0),
        meas_mode=pk.MM_6D_CONTINUOUS_DISTANCE,
        rotation_status=3,
    )
    assert len(packet) == 68 + 2 * 212
    assert pk.HEADER.unpack_from(packet) == (len(packet), pk.DataType.CONTINUOUS_PROBE_MEAS_RESULT)
    result = pk.decode_server_packet(packet)
    assert isinstance(result, pk.MultiMeasResult)
    assert result.meas_mode == 8 and result.meteo == (20.0, 1013.0, 50.0)
    first, second = result.records
    assert (first.time1, first.time2, first.values, first.quaternion) == (2, 1, (1.0, 2.0, 3.0), q)
    assert first.rotation_status == 3 and second.status == 1
    # The quaternion sits after position (3), its std (4) and covariances (3): byte
    # 68 + 20 + 10 * 8 of the packet.
    assert np.frombuffer(packet, "<f8", 4, 68 + 20 + 80).tolist() == list(q)
    # A reflector's MeasValueT has no orientation.
    multi = pk.decode_server_packet(pk.encode_multi_meas_result([(0, 5, (1.0, 2.0, 3.0))], AIR))
    assert multi.records[0].quaternion is None  # type: ignore[union-attr]


def test_a_probe_record_with_an_invalid_rotation_or_not_a_rotation_is_flagged_or_dropped():
    trk = EmsconTracker("127.0.0.1", 1)  # never connected: stream_reading is pure
    q = tuple(rotations.rotvec_to_quaternion(ROT0)[0])

    def reading(status: int, quaternion):
        packet = pk.decode_server_packet(
            pk.encode_probe_continuous_result(
                [(0, 7, (2000.0, 0.0, 0.0), quaternion)], AIR, rotation_status=status
            )
        )
        return trk.stream_reading(packet, packet.records[0], 7)  # type: ignore[union-attr]

    good = reading(1, q)
    assert good is not None and good.accurate
    np.testing.assert_allclose(good.rotvec_rad, ROT0, atol=1e-12)
    assert not reading(0, q).accurate  # bit 0 clear: no valid 6-DoF values
    assert not reading(3, q).accurate  # bit 1: a 6-DoF error
    assert reading(1, (2.0, 0.0, 0.0, 0.0)) is None  # not a unit quaternion
    assert reading(1, (float("nan"), 0.0, 0.0, 1.0)) is None


# ---------------------------------------------------------------- distance mode


def test_distance_mode_sends_a_point_per_distance_moved_at_the_targets_place(reflector):
    sim, trk = reflector
    t0 = time.monotonic()
    with trk.stream(distance_mm=STEP_MM, count=25, stall_timeout_s=2.0) as stream:
        rec = stream.collect(100)
    elapsed = time.monotonic() - t0
    assert sim.continuous_distance == (STEP_MM, 25) and stream.distance_mm == STEP_MM
    assert stream.rate_hz is None and stream.separation_ms is None and not stream.six_dof
    np.testing.assert_array_equal(rec.n, np.arange(1, 26))
    assert (stream.lost, stream.stale, stream.broken, stream.bad) == (0, 0, 0, 0)
    # Each point is where the target was at its stamp less the latency.
    np.testing.assert_allclose(rec.point_mm, truth(rec.t_us), atol=1e-9)
    # Points are STEP_MM apart, plus less than one 1 ms check's travel (0.114 mm).
    steps = np.linalg.norm(np.diff(rec.point_mm, axis=0), axis=1)
    assert np.all(steps >= STEP_MM) and np.all(steps < STEP_MM + SPEED * 1e-3), steps
    # ... so the stamps follow the speed: 2.044 mm at 113.6 mm/s is 18 ms.
    np.testing.assert_array_equal(np.diff(rec.t_us), 18_000)
    assert rec.rotvec_rad is None  # a reflector: no orientation, and the record says so
    assert 0.4 < elapsed < 5.0  # 24 steps of 18 ms (0.43 s), on a loaded machine
    assert sim.meas_mode == pk.MM_STATIONARY  # leaving the block stopped it


def test_a_beam_break_in_distance_mode_is_marked_once_and_no_point_is_stale(reflector):
    sim, trk = reflector
    sim.arm_fault("SAMPLE+100 beam_break count=50")  # 50 ms without a point, from check 100
    with trk.stream(distance_mm=STEP_MM, count=12, stall_timeout_s=2.0) as stream:
        samples = list(stream)
    marks = [s for s in samples if s.reading is None]
    assert len(marks) == 1 and marks[0].beam_broken
    assert marks[0].code == pk.ResultStatus.MEASUREMENT_STATUS_NOT_READY
    assert [s.n for s in samples] == list(range(1, 14))  # 12 points and the mark, in order
    at = samples.index(marks[0])
    # Checks run every ms from the start: the first point at check 1, then one per 18
    # checks; the break hits check 100, after the point of check 91 (the 6th).
    assert at == 6
    # A mark has no due time in distance mode: 1 us after the last point.
    assert marks[0].device_time_us == samples[at - 1].device_time_us + 1
    points = [s for s in samples if s.reading is not None]
    t_us = np.array([s.device_time_us for s in points])
    assert np.all(np.diff(t_us) > 0)
    np.testing.assert_allclose([s.reading.point_mm for s in points], truth(t_us), atol=1e-9)
    # After the break (checks 100..149) the target had moved on: the next point comes at
    # the first check that sees it again (150), 59 checks' travel (6.70 mm) from the last
    # one, never a point from before.
    gap = np.linalg.norm(points[at].reading.point_mm - points[at - 1].reading.point_mm)
    assert gap == pytest.approx(59 * SPEED * 1e-3, abs=1e-6)
    assert (stream.lost, stream.stale) == (0, 0)


def test_a_silent_distance_stream_raises_within_its_timeout(reflector):
    sim, trk = reflector
    sim.arm_fault("SAMPLE+200 stall delay=3.0")  # silent for 3 s from check 200 (~0.2 s)
    stall_timeout_s = 0.4
    with pytest.raises(StreamStalled, match="no result within 0.4 s"):
        with trk.stream(distance_mm=STEP_MM, stall_timeout_s=stall_timeout_s) as stream:
            t_last = time.monotonic()
            for _ in stream:
                t_last = time.monotonic()
    waited = time.monotonic() - t_last
    assert stall_timeout_s <= waited < stall_timeout_s + 0.8
    assert stream.ended and sim.meas_mode == pk.MM_STATIONARY  # StopMeasurement was sent
    assert trk.measure().point_mm.shape == (3,)  # and the tracker measures again


def test_a_target_held_still_sends_nothing_in_distance_mode_so_the_stream_stalls(reflector):
    sim, trk = reflector
    sim.set_target(START)  # held still: nothing moves by STEP_MM
    with pytest.raises(StreamStalled), trk.stream(distance_mm=STEP_MM, stall_timeout_s=0.3) as st:
        got = [s.n for s in st]
    assert st.ended
    sim.set_motion(motion)
    with trk.stream(distance_mm=STEP_MM, count=3, stall_timeout_s=2.0) as again:
        got = [s.n for s in again]
    assert got == [1, 2, 3]  # a new stream starts afresh, numbered from 1


class _Repeating(EmsconSimulator):
    """A server that sends each distance-mode point twice."""

    def stream_tick(self, n, stamp_s):
        out = super().stream_tick(n, stamp_s)
        return [*out, *[o for o in out if isinstance(o, Send) and o.data[4] == 3]]


def test_repeated_distance_points_are_dropped_as_stale():
    sim = _sim(_Repeating)
    server, trk = _served(sim)
    try:
        with trk.stream(distance_mm=STEP_MM, count=8, stall_timeout_s=2.0) as st:
            rec = st.collect(100)
    finally:
        trk.close()
        server.stop()
    np.testing.assert_array_equal(rec.n, np.arange(1, 9))
    assert st.stale == 7 and st.lost == 0  # the 8th point's repeat came after the end
    np.testing.assert_allclose(rec.point_mm, truth(rec.t_us), atol=1e-9)


def test_distance_options_out_of_range_are_refused_before_anything_is_sent(reflector):
    sim, trk = reflector
    with pytest.raises(ValueError, match="not both"):
        trk.stream(100, distance_mm=1.0)
    with pytest.raises(ValueError, match="not both"):
        trk.stream()
    with pytest.raises(ValueError, match="outside 0.001"):
        trk.stream(distance_mm=0.0)
    assert sim.meas_mode == pk.MM_STATIONARY


# ---------------------------------------------------------------- 6-DoF


@pytest.mark.parametrize("distance", [False, True])
def test_a_probe_streams_its_orientation_in_the_6dof_modes(probe, distance):
    sim, trk = probe
    kind = {"distance_mm": STEP_MM} if distance else {"rate_hz": 100}
    with trk.stream(count=10, stall_timeout_s=2.0, **kind) as stream:  # type: ignore[arg-type]
        assert sim.meas_mode == (
            pk.MM_6D_CONTINUOUS_DISTANCE if distance else pk.MM_6D_CONTINUOUS_TIME
        )
        rec = stream.collect(100)
    assert stream.six_dof  # asked of the server: ES_MSI_MeasurementProbeFound
    np.testing.assert_array_equal(rec.n, np.arange(1, 11))
    np.testing.assert_allclose(rec.point_mm, truth(rec.t_us), atol=1e-9)
    assert rec.rotvec_rad is not None
    np.testing.assert_allclose(rec.rotvec_rad, true_rotvec(rec.t_us), atol=1e-9)
    assert rec.accurate.all()


def test_a_probe_can_stream_positions_only_and_a_reflector_refuses_the_6dof_mode(probe, reflector):
    psim, ptrk = probe
    with ptrk.stream(100, count=5, stall_timeout_s=2.0, six_dof=False) as stream:
        assert psim.meas_mode == pk.MM_CONTINUOUS_TIME
        rec = stream.collect(10)
    assert rec.rotvec_rad is None and len(rec.n) == 5
    rsim, rtrk = reflector
    with pytest.raises(EmsconRefused):
        rtrk.stream(100, six_dof=True)
    assert rsim.meas_mode == pk.MM_STATIONARY  # set back after the refusal
