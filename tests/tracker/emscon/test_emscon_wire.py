"""Wire-level cases a well-behaved simulator never produces, scripted byte for byte.

A subclass of the simulator answers chosen commands with raw packets; every
other command gets the simulator's normal answer over the real server.
"""

from __future__ import annotations

import threading
import time
from collections import deque

import numpy as np
import pytest
from emscon_kit import TARGET_MM

from drivers.tracker.averaging import measure_average
from drivers.tracker.emscon import EmsconTracker
from drivers.tracker.emscon import protocol as pk
from drivers.tracker.emscon.errors import (
    BadReading,
    EmsconRefused,
    FrameError,
    TargetUnstable,
    TrackerGone,
    TrackerTimeout,
)
from drivers.tracker.emscon.simulator import EmsconServer, EmsconSimulator
from drivers.tracker.emscon.simulator.engine import FAULT_NAMES
from drivers.tracker.instrument import NoiseModel
from drivers.tracker.line.simulator.engine import Send


class ScriptedSimulator(EmsconSimulator):
    """Answers the next commands of a kind with scripted raw packets, one answer per command."""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.scripts: dict[str, list[list[bytes]]] = {}

    def handle_packet(self, data):
        answers = self.scripts.get(FAULT_NAMES.get(pk.parse_uint(data[8:12]), "UNKNOWN"))
        if answers:
            return [p if isinstance(p, Send) else Send(p) for p in answers.pop(0)]
        return super().handle_packet(data)


@pytest.fixture
def scripted():
    sim = ScriptedSimulator(seed=2, initialised=True, noise=NoiseModel(enabled=False))
    sim.set_target(TARGET_MM)
    server = EmsconServer(sim)
    server.open()
    server.start()
    trk = EmsconTracker("127.0.0.1", server.port, timeout_s=0.5, reconnect_delay_s=0.01)
    trk.connect()
    yield sim, trk
    trk.close()
    server.stop()


def _result(values, std=(0.0, 0.0, 0.0, 0.0), meteo=(20.0, 1013.25, 50.0), **kwargs):
    return pk.encode_single_meas_result(values, std, meteo, **kwargs)


STALE = (9.0, 9.0, 9.0)  # the abandoned measurement's point: must never be handed out


def test_unknown_tracker_status_value_is_a_frame_error_after_one_retry(scripted):
    sim, trk = scripted
    bad = pk.encode_reply(pk.Command.GET_TRACKER_STATUS, 0, pk.uint_param(7))
    sim.scripts["STAT?"] = [[bad]]
    assert trk.status().state is pk.TrackerState.READY  # a query is retried once
    sim.scripts["STAT?"] = [[bad], [bad]]
    with pytest.raises(FrameError, match="unknown tracker status 7"):
        trk.status()
    assert trk.status().state is pk.TrackerState.READY


def test_unknown_packet_type_breaks_the_link_and_the_next_reading_reconnects(scripted):
    sim, trk = scripted
    sim.scripts["MEAS"] = [[pk.HEADER.pack(16, 42) + bytes(8)]]
    with pytest.raises(FrameError, match="unknown packet type 42"):
        trk.measure(timeout_s=0.5)
    np.testing.assert_array_equal(trk.measure().point_mm, TARGET_MM)


def test_result_before_its_acknowledgement_and_the_late_ack_is_ignored(scripted):
    sim, trk = scripted
    ack = pk.encode_reply(pk.Command.START_MEASUREMENT, 0)
    sim.scripts["MEAS"] = [[_result((1.0, 2.0, 3.0)), ack]]
    np.testing.assert_array_equal(trk.measure().point_mm, [1.0, 2.0, 3.0])
    assert trk.status().state is pk.TrackerState.READY  # the stray ack did not answer this
    np.testing.assert_array_equal(trk.measure().point_mm, TARGET_MM)


def test_a_result_answering_a_non_measurement_command_is_never_used(scripted):
    sim, trk = scripted
    stray = _result((9.0, 9.0, 9.0))
    real = pk.encode_reply(pk.Command.GET_TRACKER_STATUS, 0, pk.uint_param(2))
    sim.scripts["STAT?"] = [[stray, real]]
    assert trk.status().state is pk.TrackerState.READY
    assert trk._link.stale == 1
    np.testing.assert_array_equal(trk.measure().point_mm, TARGET_MM)


def test_a_size_field_that_promises_more_than_arrives_times_out_within_the_deadline(scripted):
    sim, trk = scripted
    sim.scripts["MEAS"] = [[pk.HEADER.pack(156, pk.DataType.SINGLE_MEAS_RESULT) + bytes(8)]]
    old = trk._link
    with pytest.raises(TrackerTimeout):
        trk.measure(timeout_s=0.3)
    # The stream cannot be re-cut safely: the adapter has already reconnected.
    assert old.broken and trk._link is not old and not trk._link.broken
    np.testing.assert_array_equal(trk.measure().point_mm, TARGET_MM)


# ---------------------------------------------------------------- the fence after a timeout


def _abandon_a_measurement(sim, trk):
    sim.scripts["MEAS"] = [[]]  # no answer in time: the link is unsettled
    with pytest.raises(TrackerTimeout):
        trk.measure(timeout_s=0.2)


def test_fence_answered_busy_at_once_is_waited_out_and_the_late_result_never_read(scripted):
    sim, trk = scripted
    _abandon_a_measurement(sim, trk)
    busy = pk.encode_reply(pk.Command.GET_TRACKER_STATUS, pk.ResultStatus.SERVER_BUSY)
    # The busy answer comes at once; the abandoned result 0.1 s later, then the queue.
    sim.scripts["STAT?"] = [[busy], [Send(busy), Send(_result(STALE), 0.1)]]
    reading = trk.measure(timeout_s=1.0)
    np.testing.assert_array_equal(reading.point_mm, TARGET_MM)
    assert trk._link.fence_busy == 2 and trk._link.stale == 1


def test_fence_with_the_late_result_ahead_of_its_reply_discards_it(scripted):
    sim, trk = scripted
    _abandon_a_measurement(sim, trk)
    ok = pk.encode_reply(pk.Command.GET_TRACKER_STATUS, 0, pk.uint_param(2))
    sim.scripts["STAT?"] = [[_result(STALE), ok]]
    np.testing.assert_array_equal(trk.measure().point_mm, TARGET_MM)
    assert trk._link.stale == 1 and trk._link.fence_busy == 0


def test_fence_refused_raises_that_error_and_fences_again_next_time(scripted):
    sim, trk = scripted
    _abandon_a_measurement(sim, trk)
    refused = pk.encode_error(pk.Command.GET_TRACKER_STATUS, 38)  # ES_RS_NoTrackerConnected
    sim.scripts["STAT?"] = [[refused]]
    before = sim.measurements
    with pytest.raises(EmsconRefused) as err:
        trk.measure()
    assert err.value.code == 38 and err.value.command == "ES_C_GET_TRACKER_STATUS"
    assert err.value.detail == "fence before ES_C_START_MEASUREMENT"
    assert sim.measurements == before  # no measurement was started behind a failed fence
    late = pk.encode_reply(pk.Command.GET_TRACKER_STATUS, 0, pk.uint_param(2))
    sim.scripts["STAT?"] = [[_result(STALE), late]]  # the next fence settles it
    np.testing.assert_array_equal(trk.measure().point_mm, TARGET_MM)
    assert trk._link.stale == 1


def test_fence_busy_until_the_deadline_is_a_timeout_and_stays_unsettled(scripted):
    sim, trk = scripted
    _abandon_a_measurement(sim, trk)
    busy = pk.encode_reply(pk.Command.GET_TRACKER_STATUS, pk.ResultStatus.SERVER_BUSY)
    sim.scripts["STAT?"] = [[busy]] * 1000
    trk._link.busy_poll_s = 5.0  # the pause never outlasts the deadline
    start = time.monotonic()
    with pytest.raises(TrackerTimeout, match="no answer to ES_C_START_MEASUREMENT"):
        trk.measure(timeout_s=0.3)
    assert time.monotonic() - start < 1.5
    sim.scripts["STAT?"] = []
    np.testing.assert_array_equal(trk.measure().point_mm, TARGET_MM)


# ---------------------------------------------------------------- what a result may say


def test_try_mode_reading_is_flagged_and_never_averaged_as_real(scripted):
    sim, trk = scripted
    sim.scripts["MEAS"] = [[_result((2100.0, 300.0, -200.0), try_mode=True)]]
    avg = measure_average(trk, 10)
    assert not avg.readings[0].accurate and all(r.accurate for r in avg.readings[1:])
    assert (avg.count, avg.rejected) == (9, 1)
    np.testing.assert_array_equal(avg.mean_mm, TARGET_MM)


def test_result_with_a_non_zero_status_is_its_error_never_a_reading(scripted):
    sim, trk = scripted
    sim.scripts["MEAS"] = [
        [_result(STALE, status=pk.ResultStatus.NO_STATIONARY_RESULT)],
        [_result(STALE, status=29)],  # ES_RS_NoVideoCamera: known, nothing special
    ]
    with pytest.raises(TargetUnstable) as err:
        trk.measure()
    assert err.value.code == 10009 and err.value.command == "ES_C_START_MEASUREMENT"
    with pytest.raises(EmsconRefused):
        trk.measure()
    np.testing.assert_array_equal(trk.measure().point_mm, TARGET_MM)


@pytest.mark.parametrize(
    ("values", "std", "meteo"),
    [
        ((np.nan, 300.0, -200.0), (0.0, 0.0, 0.0, 0.0), (20.0, 1013.25, 50.0)),
        ((2000.0, np.inf, -200.0), (0.0, 0.0, 0.0, 0.0), (20.0, 1013.25, 50.0)),
        ((1e300, 300.0, -200.0), (0.0, 0.0, 0.0, 0.0), (20.0, 1013.25, 50.0)),
        ((2000.0, 300.0, -200.0), (0.0, np.nan, 0.0, 0.0), (20.0, 1013.25, 50.0)),
        ((2000.0, 300.0, -200.0), (0.0, 0.0, 0.0, 1e300), (20.0, 1013.25, 50.0)),
        ((2000.0, 300.0, -200.0), (0.0, 0.0, 0.0, -np.inf), (20.0, 1013.25, 50.0)),
        ((2000.0, 300.0, -200.0), (0.0, 0.0, 0.0, 0.0), (20.0, np.nan, 50.0)),
    ],
)
def test_non_finite_or_absurd_values_are_a_bad_reading_and_the_link_stays(
    scripted, values, std, meteo
):
    sim, trk = scripted
    sim.scripts["MEAS"] = [[_result(values, std, meteo)]]
    link = trk._link
    with pytest.raises(BadReading, match="impossible values") as err:
        trk.measure()
    assert isinstance(err.value, FrameError)  # a ReadingLost: the pose is measured again
    np.testing.assert_array_equal(trk.measure().point_mm, TARGET_MM)
    assert trk._link is link and not link.broken


# ---------------------------------------------------------------- packets of the full header


def _multi(type_, head, record, count, claimed=None):
    body = pk.uint_param(0) + pk.uint_param(count if claimed is None else claimed)
    return pk.HEADER.pack(head + count * record, type_) + body + bytes(head + count * record - 16)


def test_result_types_of_the_full_header_are_skipped_by_their_size(scripted):
    sim, trk = scripted
    others = [
        _multi(pk.DataType.MULTI_MEAS_RESULT, 48, 36, 200),  # 7248 bytes: over the old 4096
        _multi(pk.DataType.MULTI_MEAS_RESULT2, 48, 92, 0),
        _multi(pk.DataType.CONTINUOUS_PROBE_MEAS_RESULT, 68, 212, 3),
        pk.HEADER.pack(108, pk.DataType.PROBE_POS_RESULT) + bytes(100),
    ]
    sim.scripts["MEAS"] = [[*others, _result((1.0, 2.0, 3.0))]]
    link = trk._link
    np.testing.assert_array_equal(trk.measure().point_mm, [1.0, 2.0, 3.0])
    assert trk._link is link and not link.broken and link.stale == 4


@pytest.mark.parametrize(
    "packet",
    [
        _multi(pk.DataType.MULTI_MEAS_RESULT, 48, 36, 2, claimed=3),  # count disagrees
        pk.HEADER.pack(48 + 35, pk.DataType.MULTI_MEAS_RESULT) + bytes(75),  # not whole records
        pk.HEADER.pack(107, pk.DataType.PROBE_POS_RESULT) + bytes(99),  # fixed size wrong
        pk.HEADER.pack(pk.MAX_PACKET + 36, pk.DataType.MULTI_MEAS_RESULT),  # over the bound
    ],
)
def test_full_header_packets_whose_size_disagrees_break_the_link(scripted, packet):
    sim, trk = scripted
    sim.scripts["MEAS"] = [[packet]]
    with pytest.raises(FrameError, match="^while waiting for ES_C_START_MEASUREMENT: "):
        trk.measure(timeout_s=0.5)
    np.testing.assert_array_equal(trk.measure().point_mm, TARGET_MM)


# ---------------------------------------------------------------- half a packet, then silence


def test_half_a_packet_then_silence_is_detected_fast_and_the_link_reconnected(scripted):
    sim, trk = scripted
    sim.scripts["MEAS"] = [[_result((1.0, 2.0, 3.0))[:70]]]
    old = trk._link
    start = time.monotonic()
    with pytest.raises(TrackerTimeout, match="stopped arriving while waiting for ES_C_START_ME"):
        trk.measure(timeout_s=10.0)  # a long measurement deadline is not waited out
    assert time.monotonic() - start < trk.timeout_s + 1.0
    assert old.broken and not trk._link.broken  # reconnected already
    np.testing.assert_array_equal(trk.measure().point_mm, TARGET_MM)


def test_a_server_that_keeps_cutting_packets_is_given_up_not_retried_forever(scripted):
    sim, trk = scripted
    half = _result((1.0, 2.0, 3.0))[:70]
    sim.scripts["MEAS"] = [[half]] * 10
    for _ in range(2):
        with pytest.raises(TrackerTimeout):
            trk.measure(timeout_s=10.0)
    with pytest.raises(
        TrackerGone, match="cut 3 packets short in a row, each on a fresh connection: giving up$"
    ):
        trk.measure(timeout_s=10.0)


def test_fence_keeps_events_and_skips_other_replies_until_its_own(scripted):
    sim, trk = scripted
    _abandon_a_measurement(sim, trk)
    late_ack = pk.encode_reply(pk.Command.START_MEASUREMENT, 0)
    event = pk.encode_status_change(pk.StatusChange.MEAS_STATUS_READY)
    ok = pk.encode_reply(pk.Command.GET_TRACKER_STATUS, 0, pk.uint_param(2))
    sim.scripts["STAT?"] = [[late_ack, event, _result(STALE), ok]]
    trk.events.clear()
    np.testing.assert_array_equal(trk.measure().point_mm, TARGET_MM)
    assert [e.change for e in trk.events] == [pk.StatusChange.MEAS_STATUS_READY]
    assert trk._link.stale == 2  # the late ack and the late result


def _spy_on_commands(sim):
    """The command codes ``sim`` receives from now on, in order (a list it fills)."""
    commands = []
    handle = sim.handle_packet

    def spy(data):
        commands.append(pk.parse_uint(data[8:12]))
        return handle(data)

    sim.handle_packet = spy
    return commands


def test_a_settled_link_sends_no_further_fence(scripted):
    sim, trk = scripted
    _abandon_a_measurement(sim, trk)
    commands = _spy_on_commands(sim)
    trk.measure()
    trk.measure()
    fence, meas = pk.Command.GET_TRACKER_STATUS, pk.Command.START_MEASUREMENT
    assert commands == [fence, meas, meas]


@pytest.mark.parametrize(
    ("values", "std", "accurate"),
    [
        ((1e6, -1e6, 0.0), (0.0, 0.0, 0.0, 0.05), True),  # 1 km exactly: a (far) reading
        ((2000.0, 300.0, -200.0), (0.0, 0.0, 0.0, 0.1), True),  # dStdTotal at the limit
        ((2000.0, 300.0, -200.0), (1e6, 0.0, 0.0, 1e6), False),  # huge std: only flagged
    ],
)
def test_boundary_values_are_readings(scripted, values, std, accurate):
    sim, trk = scripted
    sim.scripts["MEAS"] = [[_result(values, std)]]
    reading = trk.measure()
    np.testing.assert_array_equal(reading.point_mm, values)
    np.testing.assert_array_equal(reading.std_mm, std)
    assert reading.accurate is accurate and reading.meteo == (20.0, 1013.25, 50.0)


def test_a_bad_probe_reading_names_its_orientation_and_a_plain_one_does_not(scripted):
    sim, trk = scripted
    nan_q = pk.encode_probe_stationary_result(
        (2000.0, 300.0, -200.0), (0.0, 0.0, 0.0, 0.0), (np.nan, 0, 0, 1), (20, 1000, 40)
    )
    sim.scripts["MEAS"] = [[nan_q], [_result((np.nan, 0.0, 0.0))]]
    with pytest.raises(BadReading, match=r"meteo \[20.0, 1000.0, 40.0\], orientation \[nan"):
        trk.measure()
    with pytest.raises(BadReading) as err:
        trk.measure()
    assert str(err.value).endswith("meteo [20.0, 1013.25, 50.0]")
    # One name for the failure: the port's BadReading, raised as every tracker kind raises it.
    from calibrator.acquire import ports
    from drivers.tracker import errors as shared

    assert isinstance(err.value, ports.BadReading) and type(err.value) is shared.BadReading


def test_a_good_reading_between_cut_packets_resets_the_count(scripted):
    sim, trk = scripted
    half = _result((1.0, 2.0, 3.0))[:70]
    sim.scripts["MEAS"] = [[half], [half], [_result((1.0, 2.0, 3.0))], [half], [half]]
    for expected in (TrackerTimeout, TrackerTimeout, None, TrackerTimeout, TrackerTimeout):
        if expected is None:
            trk.measure()
            continue
        with pytest.raises(expected):
            trk.measure(timeout_s=10.0)
    np.testing.assert_array_equal(trk.measure().point_mm, TARGET_MM)  # never given up


def test_reconnect_tries_again_after_a_failed_attempt_and_names_the_failure(scripted):
    from drivers.tracker.emscon.errors import LinkDropped

    sim, trk = scripted
    sim.arm_fault("MEAS+1 hangup")
    sim.arm_fault("UNITS+1 hangup")  # the first reconnect's settings fail too
    with pytest.raises(
        LinkDropped, match="during START_MEASUREMENT; reconnected, command not repeated$"
    ):
        trk.measure()
    np.testing.assert_array_equal(trk.measure().point_mm, TARGET_MM)
    never = EmsconTracker("127.0.0.1", 1)
    with pytest.raises(TrackerGone, match=r"^not connected: call connect\(\) first$"):
        never.measure()
    trk.reconnect_attempts = 0
    sim.arm_fault("MEAS+1 hangup")
    with pytest.raises(TrackerGone, match="0 reconnect attempts failed: None"):
        trk.measure()


def test_a_timeout_names_its_command_and_a_reading_carries_the_host_clock_in_us(scripted):
    sim, trk = scripted
    sim.scripts["MEAS"] = [[]]
    with pytest.raises(TrackerTimeout, match=r"^no answer to ES_C_START_MEASUREMENT within"):
        trk.measure(timeout_s=0.1)
    before = time.monotonic_ns() // 1000
    reading = trk.measure()
    after = time.monotonic_ns() // 1000
    assert type(reading.device_time_us) is int and before <= reading.device_time_us <= after


def test_a_refusal_in_a_reply_names_its_command_and_an_error_packet_must_carry_a_status(scripted):
    sim, trk = scripted
    refused = pk.encode_reply(pk.Command.START_MEASUREMENT, pk.ResultStatus.SENSOR_NOT_STABLE)
    sim.scripts["MEAS"] = [[refused], [pk.encode_error(pk.Command.START_MEASUREMENT, 0)]]
    with pytest.raises(TargetUnstable) as err:
        trk.measure()
    assert err.value.command == "ES_C_START_MEASUREMENT" and err.value.code == 10013
    with pytest.raises(FrameError, match="^ES_DT_Error with status 0 for ES_C_START_MEASUREMENT$"):
        trk.measure()


def test_a_broken_or_failed_link_sends_nothing_and_says_so():
    import socket

    from drivers.tracker.emscon.errors import ConnectionLost
    from drivers.tracker.emscon.link import EmsconLink

    ours, theirs = socket.socketpair()
    link = EmsconLink(ours, events=deque(), packet_gap_s=1.0)
    link.broken = True
    with pytest.raises(ConnectionLost, match="^emScon link is broken: reconnect first$"):
        link.transact(pk.Command.GET_UNITS, timeout_s=0.5)
    theirs.setblocking(False)
    with pytest.raises(BlockingIOError):
        theirs.recv(16)  # not a byte went out
    link = EmsconLink(ours, events=deque(), packet_gap_s=1.0)
    ours.close()
    with pytest.raises(ConnectionLost, match="^emScon connection failed while sending: "):
        link.transact(pk.Command.GET_UNITS, timeout_s=0.5)
    assert link.broken is True
    theirs.close()


def _tcp_pair():
    import socket

    with socket.create_server(("127.0.0.1", 0)) as listener:
        ours = socket.create_connection(listener.getsockname())
        theirs, _ = listener.accept()
    return ours, theirs


def test_a_reset_or_closed_connection_while_reading_breaks_the_link_and_says_which():
    import socket
    import struct

    from drivers.tracker.emscon.errors import ConnectionLost
    from drivers.tracker.emscon.link import EmsconLink, _name

    ours, theirs = _tcp_pair()
    link = EmsconLink(ours, events=deque(), packet_gap_s=1.0)

    def reset_after_the_command():
        theirs.settimeout(10)  # a link that sends nothing fails the test, not hangs it
        theirs.recv(12)
        theirs.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
        theirs.close()  # a reset, not an orderly close

    server = threading.Thread(target=reset_after_the_command)
    server.start()
    with pytest.raises(ConnectionLost, match="^emScon connection failed while reading: "):
        link.transact(pk.Command.GET_UNITS, timeout_s=2.0)
    server.join(15)
    assert not server.is_alive()
    assert link.broken is True
    ours.close()

    ours, theirs = _tcp_pair()
    link = EmsconLink(ours, events=deque(), packet_gap_s=1.0)
    theirs.shutdown(socket.SHUT_WR)  # the server hangs up; our command still goes out
    with pytest.raises(
        ConnectionLost, match="^emScon server closed the connection during ES_C_GET_UNITS$"
    ):
        link.transact(pk.Command.GET_UNITS, timeout_s=1.0)
    assert link.broken is True
    ours.close()
    theirs.close()
    assert (_name(pk.Command.GET_UNITS), _name(9999)) == ("ES_C_GET_UNITS", "ES_C_9999")


def test_a_fresh_connection_sends_no_fence():
    sim = ScriptedSimulator(seed=2, initialised=True, noise=NoiseModel(enabled=False))
    commands = _spy_on_commands(sim)
    with EmsconServer(sim) as server:
        server.open()
        server.start()
        with EmsconTracker("127.0.0.1", server.port, timeout_s=0.5) as trk:
            trk.connect()
    assert commands[:2] == [pk.Command.SET_UNITS, pk.Command.GET_UNITS]


def test_find_reflector_keeps_its_own_deadline_for_the_search(scripted):
    sim, trk = scripted
    trk.search_timeout_s = 5.0
    sim.arm_fault("FIND+1 delay delay=1.0")
    start = time.monotonic()
    with pytest.raises(TrackerTimeout):
        trk.find_reflector(TARGET_MM, timeout_s=0.2)
    assert time.monotonic() - start < 1.0
