"""Scripted exchanges per command: the driver against a fake transport (expected-protocol style)."""

from __future__ import annotations

import numpy as np
import pytest
from tracker_kit import CONNECT_PAIRS, ScriptedTransport, expected_exchange, host, trk

from drivers.errors import DriverError, NotReady, ProtocolError
from drivers.tracker import (
    BeamBroken,
    ChecksumError,
    Environment,
    FrameError,
    FrameRejected,
    LaserTracker,
    NotInitialised,
    ReadingStatus,
    TargetUnstable,
    TrackerBusy,
    TrackerError,
    TrackerTimeout,
    read_log,
)
from drivers.tracker.line.protocol import ErrorCode


def test_connect_identifies_sets_units_and_reads_status():
    with expected_exchange(CONNECT_PAIRS) as tracker:
        status = tracker.connect()
        identity = tracker.identity
    assert (identity.vendor, identity.model, identity.serial, identity.firmware) == (
        "ACME",
        "AT-X",
        "123",
        "2.1",
    )
    assert status.state == "READY" and status.initialised and status.beam_locked
    assert not status.probe_6dof and status.mode == "STANDARD"


def test_connect_with_environment_and_mode():
    pairs = [
        CONNECT_PAIRS[0],
        CONNECT_PAIRS[1],
        (host(3, "ENV", "21.50", "1001.00", "40.0"), trk("OK,3,21.50,1001.00,40.0")),
        (host(4, "MODE", "PRECISE"), trk("OK,4,PRECISE")),
        (host(5, "STAT?"), trk("OK,5,NOT_READY,0,1,P6,PRECISE")),
    ]
    with expected_exchange(pairs) as tracker:
        status = tracker.connect(Environment(21.5, 1001.0, 40.0), mode="PRECISE")
    assert not status.initialised and status.probe_6dof and status.mode == "PRECISE"


def test_initialise_sends_init_with_the_long_deadline():
    pairs = [*CONNECT_PAIRS, (host(4, "INIT"), trk("OK,4"))]
    with expected_exchange(pairs, init_timeout_s=90.0) as tracker:
        tracker.connect()
        tracker.initialise()
        # The port's read timeout was stretched to INIT's deadline, not left at 1 s.
        assert 89.0 < tracker.link.port.timeout <= 90.0


def test_measure_3dof_reading():
    pairs = [*CONNECT_PAIRS, (host(4, "MEAS"), trk("OK,4,P3,1.5000,-2.2500,3000.1234,ACC,1234"))]
    with expected_exchange(pairs) as tracker:
        tracker.connect()
        reading = tracker.measure()
    np.testing.assert_array_equal(reading.point_mm, [1.5, -2.25, 3000.1234])
    assert reading.rotvec_rad is None
    assert reading.status is ReadingStatus.ACCURATE and reading.accurate
    assert reading.device_time_us == 1234


def test_measure_6dof_reading_with_flag():
    body = "OK,4,P6,10.0000,20.0000,30.0000,0.10000000,-0.20000000,0.30000000,UNSTABLE,99"
    pairs = [*CONNECT_PAIRS, (host(4, "MEAS"), trk(body))]
    with expected_exchange(pairs) as tracker:
        tracker.connect()
        reading = tracker.measure()
    np.testing.assert_array_equal(reading.point_mm, [10.0, 20.0, 30.0])
    np.testing.assert_array_equal(reading.rotvec_rad, [0.1, -0.2, 0.3])
    assert reading.status is ReadingStatus.UNSTABLE and not reading.accurate


def test_stop():
    pairs = [*CONNECT_PAIRS, (host(4, "STOP"), trk("OK,4"))]
    with expected_exchange(pairs) as tracker:
        tracker.connect()
        tracker.stop()


def test_simulator_only_command_passes_through_send():
    pairs = [*CONNECT_PAIRS, (host(4, "SIM", "TARGET", "1", "2", "3"), trk("OK,4"))]
    with expected_exchange(pairs) as tracker:
        tracker.connect()
        tracker.send("SIM", "TARGET", "1", "2", "3")


@pytest.mark.parametrize(
    ("code", "cls", "also"),
    [
        (ErrorCode.BEAM_BROKEN, BeamBroken, DriverError),
        (ErrorCode.NO_TARGET, BeamBroken, DriverError),
        (ErrorCode.NOT_INITIALISED, NotInitialised, NotReady),
        (ErrorCode.TARGET_UNSTABLE, TargetUnstable, TrackerError),
        (ErrorCode.BUSY, TrackerBusy, NotReady),
        (ErrorCode.BAD_FRAME, FrameRejected, ProtocolError),
        (ErrorCode.OUT_OF_RANGE, TrackerError, IOError),
        (ErrorCode.NOT_WARMED_UP, TrackerError, IOError),
    ],
)
def test_er_replies_raise_typed_errors(code, cls, also):
    reply = trk(f"ER,4,{int(code)},{code.name},detail text")
    with expected_exchange([*CONNECT_PAIRS, (host(4, "MEAS"), reply)]) as tracker:
        tracker.connect()
        with pytest.raises(cls) as info:
            tracker.measure()
    assert isinstance(info.value, also)
    assert info.value.code == code and info.value.text == code.name
    assert info.value.detail == "detail text" and info.value.command == "MEAS"


def test_meteo_out_of_range_is_a_tracker_error_and_not_remembered():
    pairs = [
        *CONNECT_PAIRS,
        (host(4, "ENV", "80.00", "1013.25", "50.0"), trk("ER,4,9,METEO_OUT_OF_RANGE,T=80.0")),
    ]
    with expected_exchange(pairs) as tracker:
        tracker.connect()
        with pytest.raises(TrackerError, match="METEO_OUT_OF_RANGE"):
            tracker.set_environment(Environment(80.0))
        assert "ENV" not in tracker._settings


def test_stale_reply_and_event_are_skipped():
    stale = trk("OK,3,READY,1,1,P3,STANDARD")
    event = trk("EV,0,20,BEAM_RESTORED")
    reading = trk("OK,4,P3,1.0000,2.0000,3.0000,ACC,5")
    events = []
    pairs = [*CONNECT_PAIRS, (host(4, "MEAS"), stale + event + reading)]
    with expected_exchange(pairs, on_event=events.append) as tracker:
        tracker.connect()
        np.testing.assert_array_equal(tracker.measure().point_mm, [1.0, 2.0, 3.0])
        assert tracker.link.stale_replies == 1
    assert [(e.code, e.text) for e in events] == [(20, "BEAM_RESTORED")]
    assert list(tracker.events) == events


def test_garbled_query_reply_is_retried_once():
    garbled = b"OK,4,RE#DY,1,1,P3\r\n"
    pairs = [
        *CONNECT_PAIRS,
        (host(4, "STAT?"), garbled),
        (host(5, "STAT?"), trk("OK,5,READY,1,1,P3,FAST")),
    ]
    with expected_exchange(pairs) as tracker:
        tracker.connect()
        assert tracker.status().mode == "FAST"


def test_query_garbled_twice_raises():
    bad = trk("OK,4,READY,1,1,P3,FAST")[:-7] + b"*0000\r\n"
    pairs = [*CONNECT_PAIRS, (host(4, "ID?"), bad), (host(5, "ID?"), bad)]
    with expected_exchange(pairs) as tracker:
        tracker.connect()
        with pytest.raises(ChecksumError):
            tracker.query_identity()


def test_bad_checksum_on_measure_is_raised_and_not_retried():
    good = trk("OK,4,P3,1.0000,2.0000,3.0000,ACC,5")
    bad = good[:-7] + b"*%04X\r\n" % (int(good[-6:-2], 16) ^ 1)
    second = trk("OK,5,P3,7.0000,8.0000,9.0000,ACC,6")
    pairs = [*CONNECT_PAIRS, (host(4, "MEAS"), bad), (host(5, "MEAS"), second)]
    transport = ScriptedTransport(pairs)
    tracker = LaserTracker(transport, reconnect_attempts=0)
    tracker.connect()
    with pytest.raises(ChecksumError):
        tracker.measure()
    assert transport.used == 4  # the reading was not silently re-requested
    # Only an explicit second call consumes the next pair, and it works.
    np.testing.assert_array_equal(tracker.measure().point_mm, [7.0, 8.0, 9.0])
    transport.verify()


def test_timeout_keeps_partial_bytes_and_late_reply_is_dropped():
    reply4 = trk("OK,4,P3,1.0000,2.0000,3.0000,ACC,5")
    reply5 = trk("OK,5,P3,4.0000,5.0000,6.0000,ACC,6")
    pairs = [
        *CONNECT_PAIRS,
        (host(4, "MEAS"), reply4[:20]),  # half a line, then silence
        (host(5, "MEAS"), reply4[20:] + reply5),
    ]
    with expected_exchange(pairs) as tracker:
        tracker.connect()
        with pytest.raises(TrackerTimeout):
            tracker.measure(timeout_s=0.05)
        assert bytes(tracker.link._buf) == reply4[:20]
        np.testing.assert_array_equal(tracker.measure().point_mm, [4.0, 5.0, 6.0])
        assert tracker.link.stale_replies == 1


def test_dropped_reply_times_out():
    with expected_exchange([*CONNECT_PAIRS, (host(4, "MEAS"), None)]) as tracker:
        tracker.connect()
        with pytest.raises(TrackerTimeout):
            tracker.measure(timeout_s=0.05)


@pytest.mark.parametrize(
    "body",
    [
        "OK,4,P3,1.0,2.0,ACC,5",  # a coordinate missing
        "OK,4,P3,1.0,2.0,x,ACC,5",  # not a number
        "OK,4,P3,1.0,2.0,3.0,GOOD,5",  # unknown flag
        "OK,4,P6,1.0,2.0,3.0,ACC,5",  # 6-DoF tag without orientation
        "OK,4,P3,nan,2.0,3.0,ACC,5",  # not finite
        "OK,4,P3,1.0,2.0,3.0,ACC,5.5",  # timestamp not an integer
    ],
)
def test_malformed_reading_is_a_frame_error(body):
    with expected_exchange([*CONNECT_PAIRS, (host(4, "MEAS"), trk(body))]) as tracker:
        tracker.connect()
        with pytest.raises(FrameError):
            tracker.measure()


def test_overlong_line_is_a_frame_error():
    with expected_exchange([*CONNECT_PAIRS, (host(4, "MEAS"), b"X" * 256)]) as tracker:
        tracker.connect()
        with pytest.raises(FrameError, match="no line end"):
            tracker.measure()


def test_recording_logs_raw_exchange(tmp_path):
    log = tmp_path / "raw.jsonl"
    pairs = [*CONNECT_PAIRS, (host(4, "MEAS"), trk("OK,4,P3,1.0000,2.0000,3.0000,ACC,5"))]
    with expected_exchange(pairs, record=log) as tracker:
        tracker.connect()
        tracker.measure()
        tracker.close()
    entries = read_log(log)
    tx = [e.data for e in entries if e.direction == "tx"]
    rx = b"".join(e.data for e in entries if e.direction == "rx")
    assert tx == [p[0] for p in pairs]
    assert rx == b"".join(p[1] for p in pairs)
    assert all(b.t_s >= a.t_s for a, b in zip(entries, entries[1:], strict=False))
