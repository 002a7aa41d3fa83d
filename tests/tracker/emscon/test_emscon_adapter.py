"""Our emScon adapter against the simulator over loopback TCP: results, faults, deadlines.

Every failure must be a typed error raised within its deadline, and a reading
is never handed to a command other than the one that asked for it.
"""

from __future__ import annotations

import time

import numpy as np
import pytest
from emscon_kit import ENV, TARGET_MM

from calibrator.acquire import ports
from calibrator.acquire.ports import ReadingLost, Tracker, TrackerUnavailable
from drivers.errors import DriverError
from drivers.tracker.averaging import measure_average
from drivers.tracker.emscon import EmsconTracker, open_tracker
from drivers.tracker.emscon import protocol as pk
from drivers.tracker.emscon.errors import (
    BeamBroken,
    EmsconRefused,
    FrameError,
    IdentityChanged,
    LinkDropped,
    NotInitialised,
    TargetUnstable,
    TrackerGone,
    TrackerTimeout,
    UnknownStatus,
)
from drivers.tracker.emscon.simulator import EmsconServer, EmsconSimulator

DEADLINE_SLACK_S = 0.5  # scheduling on a loaded 2-core machine


class Timer:
    def __enter__(self):
        self.start = time.monotonic()
        return self

    def __exit__(self, *exc):
        self.elapsed = time.monotonic() - self.start


def test_connect_sets_units_frame_mode_environment_and_never_initialises(served):
    sim, server = served
    sim.initialised = False
    trk = EmsconTracker("127.0.0.1", server.port, environment=ENV, timeout_s=1.0)
    assert isinstance(trk, Tracker)
    try:
        status = trk.connect()
        assert not status.initialised and status.state is pk.TrackerState.NOT_READY
        assert status.serial == sim.serial and status.version == (3, 6, 0)
        assert sim.units == pk.parse_units(pk.units_params())  # mm, rad, degC, hPa, %RH
        assert sim.env == (ENV.temperature_c, ENV.pressure_hpa, ENV.humidity_pct)
        assert not sim.initialised  # connect never moves the head
        with pytest.raises(NotInitialised) as err:
            trk.measure()
        assert err.value.code == 39 and not isinstance(err.value, ReadingLost)
        assert not sim.initialised
        trk.initialise(timeout_s=2.0)  # only on request
        assert sim.initialised and trk.status().state is pk.TrackerState.READY
    finally:
        trk.close()
        trk.close()  # twice is fine


def test_ten_reading_average_is_at_the_target_with_the_environment_passed_through(tracker):
    sim, trk = tracker
    avg = measure_average(trk, 10)
    assert avg.count == 10 and avg.rejected == 0
    # Noise at 2 m: about 5-13 um per axis; ten readings average well inside 20 um.
    np.testing.assert_allclose(avg.mean_mm, TARGET_MM, atol=0.02)
    assert np.all(avg.std_mm > 0) and np.all(avg.std_mm < 0.05)
    r = avg.readings[0]
    assert r.rotvec_rad is None and r.accurate
    assert r.meteo == (ENV.temperature_c, ENV.pressure_hpa, ENV.humidity_pct)
    times = [x.device_time_us for x in avg.readings]
    assert times == sorted(times)
    assert sim.measurements == 10


def test_beam_break_mid_average_runs_a_reflector_search_then_the_pose_measures(tracker):
    sim, trk = tracker
    trk.measure()  # gives the adapter a distance to search at
    sim.arm_fault("MEAS+5 beam_break count=100")  # stays broken until a search
    with Timer() as t, pytest.raises(BeamBroken) as err:
        measure_average(trk, 10)
    assert t.elapsed < trk.measure_timeout_s + trk.search_timeout_s
    assert isinstance(err.value, ReadingLost) and err.value.code == 10004
    assert trk.searches == 1 and "re-locked" in " ".join(err.value.__notes__)
    assert any(e.change == pk.StatusChange.MEAS_STATUS_NOT_READY for e in trk.events)
    assert any(e.change == pk.StatusChange.MEAS_STATUS_READY for e in trk.events)
    avg = measure_average(trk, 10)  # the loop measures the pose again
    np.testing.assert_allclose(avg.mean_mm, TARGET_MM, atol=0.02)


def test_dropped_connection_reconnects_without_repeating_the_reading(tracker):
    sim, trk = tracker
    sim.arm_fault("MEAS+1 hangup")
    before = sim.measurements
    with Timer() as t, pytest.raises(LinkDropped) as err:
        trk.measure()
    assert isinstance(err.value, ReadingLost) and isinstance(err.value, DriverError)
    assert t.elapsed < trk.measure_timeout_s + DEADLINE_SLACK_S
    # One measurement ran (its answer died with the connection); it was not re-requested.
    assert sim.measurements == before + 1
    reading = trk.measure()  # reconnected, settings re-applied
    np.testing.assert_allclose(reading.point_mm, TARGET_MM, atol=0.1)
    assert sim.measurements == before + 2
    assert sim.units == pk.parse_units(pk.units_params())


def test_server_gone_is_tracker_unavailable_within_bounded_reconnects(served):
    sim, server = served
    trk = EmsconTracker("127.0.0.1", server.port, timeout_s=0.5, reconnect_delay_s=0.01)
    trk.connect()
    server.stop()
    with Timer() as t, pytest.raises(TrackerGone, match="attempts failed: cannot connect") as err:
        trk.measure(timeout_s=0.5)
    assert isinstance(err.value, TrackerUnavailable)
    assert t.elapsed < 0.5 + trk.reconnect_attempts * (0.5 + 0.01) + DEADLINE_SLACK_S
    trk.close()


def test_unknown_status_code_is_a_typed_error_and_the_link_stays_usable(tracker):
    sim, trk = tracker
    sim.force_status("MEAS", 4242)  # not an ES_ResultStatus of the V3.6 header
    with pytest.raises(UnknownStatus) as err:
        trk.measure()
    assert err.value.code == 4242 and "UNKNOWN(4242)" in str(err.value)
    sim.force_status("MEAS", 29)  # ES_RS_NoVideoCamera: known, nothing special
    with pytest.raises(EmsconRefused):
        trk.measure()
    np.testing.assert_allclose(trk.measure().point_mm, TARGET_MM, atol=0.1)


def test_packet_whose_size_disagrees_with_its_type_is_a_frame_error_then_resync(tracker):
    sim, trk = tracker
    sim.arm_fault("MEAS+1 bad_crc")  # the result arrives with lPacketSize 16
    with Timer() as t, pytest.raises(FrameError) as err:
        trk.measure()
    assert t.elapsed < trk.measure_timeout_s + DEADLINE_SLACK_S
    assert "SINGLE_MEAS_RESULT" in str(err.value) and isinstance(err.value, ReadingLost)
    sim.arm_fault("MEAS+1 garble")  # an impossible size field
    with pytest.raises(FrameError):
        trk.measure()
    np.testing.assert_allclose(trk.measure().point_mm, TARGET_MM, atol=0.1)


def test_delayed_result_times_out_and_is_never_taken_for_the_next_reading(tracker):
    sim, trk = tracker
    sim.arm_fault("MEAS+1 delay delay=0.4")
    with Timer() as t, pytest.raises(TrackerTimeout):
        trk.measure(timeout_s=0.15)
    assert t.elapsed < 0.15 + DEADLINE_SLACK_S
    moved = np.array(TARGET_MM) + [0.0, 0.0, 250.0]
    sim.set_target(moved)
    # The late answer (old target) is still on its way; the next reading is the new target.
    reading = trk.measure()
    np.testing.assert_allclose(reading.point_mm, moved, atol=0.1)
    assert trk._link.stale == 1  # the late result (old target) was discarded by the fence


def test_dropped_reply_and_partial_packet(tracker):
    sim, trk = tracker
    sim.arm_fault("MEAS+1 drop")
    with pytest.raises(TrackerTimeout):
        trk.measure(timeout_s=0.2)
    sim.arm_fault("MEAS+1 partial delay=0.05")  # one packet in two TCP segments
    np.testing.assert_allclose(trk.measure().point_mm, TARGET_MM, atol=0.1)


def test_unstable_and_inaccurate_readings(tracker):
    sim, trk = tracker
    sim.arm_fault("MEAS+1 unstable")
    with pytest.raises(TargetUnstable) as err:
        trk.measure()
    assert isinstance(err.value, ReadingLost) and err.value.code == 10009
    sim.arm_fault("MEAS+1 inaccurate")
    reading = trk.measure()
    assert not reading.accurate and reading.std_mm[3] == pytest.approx(1.0)
    assert trk.measure().accurate


def test_open_tracker_parses_emscon_urls():
    trk = open_tracker("emscon://10.0.0.5", timeout_s=3.0)
    assert (trk.host, trk.port, trk.timeout_s) == ("10.0.0.5", 700, 3.0)
    assert open_tracker("emscon://127.0.0.1:7001").port == 7001
    trk = open_tracker("emscon://h?meteo=21.5,1002.5,41")
    assert trk.environment == ENV
    bad_urls = (
        "socket://127.0.0.1:700", "emscon://", "emscon://h:99999", "emscon://h/x",
        "emscon://h?meteo=21,1000", "emscon://h?meteo=a,b,c", "emscon://h?temp=20",
        "emscon://h?meteo=nan,1000,40", "emscon://h?meteo=1,2,3&meteo=1,2,3",
    )  # fmt: skip
    for bad in bad_urls:
        with pytest.raises(ValueError):
            open_tracker(bad)


def test_another_tracker_after_a_reconnect_stops_the_run(served):
    sim, server = served
    trk = EmsconTracker("127.0.0.1", server.port, timeout_s=0.5, reconnect_delay_s=0.01)
    trk.connect()
    port = server.port
    server.stop()  # the tracker goes away; another one answers on the same address
    other = EmsconSimulator(seed=1, initialised=True, serial=sim.serial + 1)
    other.set_target(TARGET_MM)
    replacement = EmsconServer(other)
    replacement.open(port)
    replacement.start()
    try:
        with pytest.raises(IdentityChanged, match=f"serial {sim.serial + 1}, not {sim.serial}"):
            trk.measure()
        assert issubclass(IdentityChanged, TrackerUnavailable)
        assert other.measurements == 0  # nothing was measured on the wrong tracker
    finally:
        trk.close()
        replacement.stop()


def test_lost_initialisation_is_reported_and_never_repaired_even_across_reconnects(tracker):
    sim, trk = tracker
    sim.arm_fault("MEAS+1 not_initialised")
    with pytest.raises(NotInitialised):
        trk.measure()
    sim.arm_fault("MEAS+1 hangup")
    with pytest.raises(LinkDropped):
        trk.measure()  # reconnected and re-applied its settings ...
    assert not sim.initialised  # ... without initialising
    assert not trk.last_status.initialised
    with pytest.raises(NotInitialised):
        trk.measure()


@pytest.mark.parametrize("ack_start", [False, True], ids=["stationary-no-ack", "acknowledged"])
def test_readings_with_and_without_a_start_acknowledgement(ack_start):
    sim = EmsconSimulator(seed=5, initialised=True, ack_start=ack_start)
    sim.set_target(TARGET_MM)
    with EmsconServer(sim) as server:
        server.open()
        server.start()
        with EmsconTracker("127.0.0.1", server.port, timeout_s=1.0) as trk:
            trk.connect()
            avg = measure_average(trk, 10)
            np.testing.assert_allclose(avg.mean_mm, TARGET_MM, atol=0.02)
            assert trk.status().state is pk.TrackerState.READY  # no stray ack answers this
            assert trk._link.stale == 0 and sim.measurements == 10


def test_find_reflector_at_a_predicted_point_relocks_only_near_the_target(tracker):
    sim, trk = tracker
    assert ports.SEARCH in trk.capabilities and ports.INITIALISE in trk.capabilities
    sim.arm_fault("MEAS+1 beam_break count=100")
    trk.search_after_beam_break = False
    with pytest.raises(BeamBroken):
        trk.measure()
    far = np.array(TARGET_MM) + [0.0, 500.0, 0.0]  # the prediction misses by 0.5 m
    with pytest.raises(BeamBroken):
        trk.find_reflector(far)
    with pytest.raises(BeamBroken):
        trk.measure()  # still broken
    trk.find_reflector(np.array(TARGET_MM) + [20.0, -10.0, 5.0])
    np.testing.assert_allclose(trk.measure().point_mm, TARGET_MM, atol=0.1)
    for bad in ([np.nan, 0.0, 0.0], [1e300, 0.0, 0.0], [1.0, 2.0]):
        with pytest.raises(ValueError):
            trk.find_reflector(bad)


def test_a_6dof_probe_feeds_orientation_through_the_probe_result():
    from scipy.spatial.transform import Rotation

    sim = EmsconSimulator(seed=3, initialised=True, probe=True)
    rotvec = np.array([0.3, -0.2, 1.1])
    sim.set_target(TARGET_MM, rotvec)
    with EmsconServer(sim) as server:
        server.open()
        server.start()
        with EmsconTracker("127.0.0.1", server.port, timeout_s=1.0) as trk:
            trk.connect()
            reading = trk.measure()
            assert reading.accurate and reading.rotvec_rad.shape == (3,)
            avg = measure_average(trk, 10)
    np.testing.assert_allclose(avg.mean_mm, TARGET_MM, atol=0.02)
    err = Rotation.from_rotvec(avg.rotvec_mean_rad) * Rotation.from_rotvec(rotvec).inv()
    assert err.magnitude() < 1e-4  # 0.01 deg MPE per reading, averaged over ten
    assert np.all(avg.rotvec_std_rad > 0)


def test_probe_result_layout_and_its_rotation_status():
    q = (np.cos(0.25), 0.0, 0.0, np.sin(0.25))  # 0.5 rad about z
    data = pk.encode_probe_stationary_result(
        (1.0, 2.0, 3.0), (0.01, 0.02, 0.03, 0.04), q, (20.0, 1000.0, 40.0)
    )
    assert len(data) == pk.SIZE_PROBE_STATIONARY_RESULT == 376
    res = pk.decode_server_packet(data)
    assert isinstance(res, pk.ProbeStationaryResult) and res.rotation_status == 1
    assert (res.values, res.std, res.quaternion) == ((1.0, 2.0, 3.0), (0.01, 0.02, 0.03, 0.04), q)
    assert res.meteo == (20.0, 1000.0, 40.0)
    trk = EmsconTracker("127.0.0.1")
    reading = trk._reading(res, 0)
    np.testing.assert_allclose(reading.rotvec_rad, [0.0, 0.0, 0.5])
    neg = pk.decode_server_packet(
        pk.encode_probe_stationary_result(
            (1.0, 2.0, 3.0), (0, 0, 0, 0), [-v for v in q], (20, 1000, 40)
        )
    )
    np.testing.assert_allclose(trk._reading(neg, 0).rotvec_rad, [0.0, 0.0, 0.5])  # -q is q
    invalid = pk.ProbeStationaryResult(**{**res.__dict__, "rotation_status": 0b11})
    assert not trk._reading(invalid, 0).accurate  # 6-DoF error bit: flagged, left out


def test_initialise_without_a_deadline_uses_the_adapters_own(tracker):
    sim, trk = tracker
    sim.initialised = False
    trk.init_timeout_s = 2.0
    trk.initialise()
    assert sim.initialised


def test_the_search_after_a_beam_break_runs_only_when_enabled_and_counts_each(tracker):
    sim, trk = tracker
    trk.measure()  # a distance to search at
    trk.search_after_beam_break = False
    sim.arm_fault("MEAS+1 beam_break count=1")
    with pytest.raises(BeamBroken):
        trk.measure()
    assert trk.searches == 0
    trk.search_after_beam_break = True
    for _ in range(2):
        sim.arm_fault("MEAS+1 beam_break count=100")
        with pytest.raises(BeamBroken):
            trk.measure()
    assert trk.searches == 2
    sim.arm_fault("MEAS+1 beam_break count=100")
    sim.clear_target()  # nothing to find: the search fails and says so
    with pytest.raises(BeamBroken) as err:
        trk.measure()
    assert any(n.startswith("FindReflector failed: ") for n in err.value.__notes__)


def test_find_reflector_checks_its_prediction_and_never_uses_the_adm(tracker):
    sim, trk = tracker
    with pytest.raises(ValueError, match="predicted point must be 3 finite mm within 1 km"):
        trk.find_reflector([1e6 + 1, 0.0, 0.0])
    with pytest.raises(EmsconRefused):  # 1 km is a prediction; the server refuses it
        trk.find_reflector([1e6, 0.0, 0.0])
    seen = []
    handle = sim.handle_packet

    def spy(data):
        if pk.parse_uint(data[8:12]) == pk.Command.GO_POSITION:
            seen.append(pk.parse_go_position(data[12:]))
        return handle(data)

    sim.handle_packet = spy
    trk.find_reflector(np.array(TARGET_MM).reshape(3, 1))  # a column vector is 3 values
    assert seen == [(TARGET_MM, False)]


def test_open_tracker_names_what_is_wrong_with_a_url():
    assert open_tracker("emscon://h/").host == "h"
    cases = {
        "socket://h": "'socket://h': expected emscon://HOST\\[:PORT\\]",
        "emscon://h:99999": "'emscon://h:99999': port 99999 is out of 1..65535",
        "emscon://h?meteo=": "meteo needs T,P,H",
        "emscon://h?&meteo=21,1000,40": "'emscon://h?&meteo=21,1000,40': parameters must be",
        "emscon://h?temp=20": "unknown parameter 'temp'",
        "emscon://h?meteo=1,2,3&meteo=1,2,3": "parameter 'meteo' given twice",
    }
    for url, message in cases.items():
        with pytest.raises(ValueError, match=message.replace("?", r"\?")):
            open_tracker(url)


def test_documented_defaults():
    trk = EmsconTracker("h")
    assert (trk.port, trk.environment, trk.meas_time_ms, trk.max_std_mm) == (700, None, None, 0.1)
    assert (trk.timeout_s, trk.measure_timeout_s) == (2.0, 10.0)
    assert (trk.init_timeout_s, trk.search_timeout_s) == (120.0, 30.0)
    assert trk.search_after_beam_break is True
    assert (trk.reconnect_attempts, trk.reconnect_delay_s) == (3, 0.2)
    assert (trk.serial, trk.last_status, trk.last_distance_mm) == (None, None, None)
    assert trk.searches == 0
    assert trk.events.maxlen == 256 and not trk.events


def test_stationary_time_is_set_on_connect_and_the_status_is_kept(served):
    sim, server = served
    trk = EmsconTracker("127.0.0.1", server.port, meas_time_ms=500, timeout_s=1.0)
    try:
        status = trk.connect()
        assert sim.stationary == (500, True)
        assert trk.last_status == status and status.initialised is True
        assert status.serial == sim.serial
    finally:
        trk.close()
    with pytest.raises(EmsconRefused):
        EmsconTracker("127.0.0.1", server.port, meas_time_ms=0, timeout_s=1.0).connect()


def test_a_server_that_does_not_confirm_the_units_is_refused_naming_both(served):
    sim, server = served
    from drivers.tracker.emscon.simulator import engine

    engine._HANDLERS[pk.Command.GET_UNITS] = lambda self, c, p: [
        pk.encode_reply(c, 0, pk.units_params(length=0))
    ]
    try:
        with pytest.raises(FrameError, match=r"did not confirm units \(1, 0, 0, 1, 0\): \(0, 0"):
            EmsconTracker("127.0.0.1", server.port, timeout_s=1.0).connect()
    finally:
        engine._HANDLERS[pk.Command.GET_UNITS] = EmsconSimulator._get_units


def test_nobody_listening_is_link_down_naming_the_address():
    with pytest.raises(TrackerGone, match=r"^cannot connect to emScon at 127\.0\.0\.1:1: "):
        EmsconTracker("127.0.0.1", 1, timeout_s=0.5).connect()
