"""Injected faults surface as their typed errors within their deadlines, and the driver recovers.

Each test arms one fault in a live simulator (served over a real pty or
127.0.0.1 TCP) and checks the error type, that it came no later than the
command's deadline plus a generous scheduling allowance, and that the next
command works where recovery is possible. The allowance only guards
against hangs; it is not a performance check. Commands expected to succeed
get generous deadlines (``LIVE_TIMEOUT_S``) so a loaded machine cannot fail
them; only replies that are meant to never come get a short one.
"""

from __future__ import annotations

import io
import json
import os
import time

import numpy as np
import pytest
from tracker_kit import LIVE_TIMEOUT_S, live_tracker

from drivers.errors import ConnectionLost, ProtocolError
from drivers.tracker import (
    BeamBroken,
    ChecksumError,
    Environment,
    FrameError,
    IdentityChanged,
    LaserTracker,
    NotInitialised,
    ReadingStatus,
    TargetUnstable,
    TrackerBusy,
    TrackerTimeout,
    measure_average,
)

SLACK_S = 5.0  # scheduling allowance on a loaded 2-core machine; a hang would blow far past it
SHORT_S = 0.3  # deadline for replies that are dropped or stay incomplete
CLOSE_S = 0.3  # pyserial's socket close() sleeps this long, once per reconnect attempt


def connected(url, **kwargs) -> LaserTracker:
    tracker = live_tracker(url, **kwargs)
    tracker.connect()
    return tracker


def raises_within(exc_type, deadline_s, func, *args):
    start = time.monotonic()
    with pytest.raises(exc_type) as info:
        func(*args)
    elapsed = time.monotonic() - start
    assert elapsed < deadline_s + SLACK_S, f"{exc_type.__name__} took {elapsed:.2f} s"
    return info.value


def assert_recovered(tracker, sim):
    reading = tracker.measure()
    assert reading.accurate
    assert np.linalg.norm(reading.point_mm - sim._target) < 0.1


@pytest.fixture(params=["pty", "tcp"])
def setup(request, served):
    sim, path, tcp = served
    tracker = connected(path if request.param == "pty" else tcp)
    yield sim, tracker
    tracker.close()


def test_beam_break_then_automatic_relock(setup):
    sim, tracker = setup
    sim.arm_fault("MEAS+1 beam_break count=2")
    for _ in range(2):
        raises_within(BeamBroken, LIVE_TIMEOUT_S, tracker.measure)
    assert_recovered(tracker, sim)
    assert [e.text for e in tracker.events] == ["BEAM_BROKEN", "BEAM_RESTORED"]


def test_beam_break_mid_set_gives_no_partial_average(setup):
    sim, tracker = setup
    sim.arm_fault("MEAS+5 beam_break")
    err = raises_within(BeamBroken, 10 * LIVE_TIMEOUT_S, measure_average, tracker, 10)
    assert err.code == 6
    # Re-measuring the same pose afterwards gives a full set.
    avg = measure_average(tracker, 10)
    assert avg.count == 10 and avg.rejected == 0
    np.testing.assert_allclose(avg.mean_mm, sim._target, atol=0.02)


def test_no_target_is_beam_broken(setup):
    sim, tracker = setup
    sim.clear_target()
    raises_within(BeamBroken, LIVE_TIMEOUT_S, tracker.measure)
    sim.set_target([1800.0, 0.0, 0.0])
    assert_recovered(tracker, sim)


def test_garbled_measurement_reply(setup):
    sim, tracker = setup
    sim.arm_fault("MEAS+1 garble")
    err = raises_within(FrameError, LIVE_TIMEOUT_S, tracker.measure)
    assert isinstance(err, ProtocolError) and not isinstance(err, ChecksumError)
    seq = tracker.link.last_seq
    assert_recovered(tracker, sim)
    assert tracker.link.last_seq == seq + 1  # one new MEAS; the lost one was not replayed


def test_garbled_query_reply_is_retried_transparently(setup):
    sim, tracker = setup
    sim.arm_fault("STAT?+1 garble")
    seq = tracker.link.last_seq
    assert tracker.status().state == "READY"
    assert tracker.link.last_seq == seq + 2


def test_bad_checksum(setup):
    sim, tracker = setup
    sim.arm_fault("MEAS+1 bad_crc")
    raises_within(ChecksumError, LIVE_TIMEOUT_S, tracker.measure)
    assert_recovered(tracker, sim)


def test_dropped_reply_times_out(setup):
    sim, tracker = setup
    sim.arm_fault("MEAS+1 drop")
    raises_within(TrackerTimeout, SHORT_S, tracker.measure, SHORT_S)
    assert_recovered(tracker, sim)


def test_partial_line_times_out_and_its_late_rest_is_dropped(setup):
    sim, tracker = setup
    sim.arm_fault("MEAS+1 partial delay=0.6")
    raises_within(TrackerTimeout, SHORT_S, tracker.measure, SHORT_S)
    # The next MEAS first reads the rest of the stale line (kept partial bytes + late rest),
    # drops it by its sequence number, then gets its own reply.
    assert_recovered(tracker, sim)
    assert tracker.link.stale_replies == 1


def test_short_delay_within_deadline_succeeds(setup):
    sim, tracker = setup
    sim.arm_fault("MEAS+1 delay delay=0.1")
    assert_recovered(tracker, sim)


def test_not_initialised_is_never_fixed_by_the_driver(setup):
    sim, tracker = setup
    sim.arm_fault("MEAS+1 not_initialised")
    raises_within(NotInitialised, LIVE_TIMEOUT_S, tracker.measure)
    raises_within(NotInitialised, LIVE_TIMEOUT_S, tracker.measure)  # still: no auto-INIT
    assert not tracker.status().initialised
    tracker.initialise()
    assert_recovered(tracker, sim)


def test_unstable_readings_are_flagged_and_rejected_from_the_average(setup):
    sim, tracker = setup
    sim.arm_fault("MEAS+3 unstable count=3")
    avg = measure_average(tracker, 10)
    flags = [r.status for r in avg.readings]
    assert flags[2:5] == [ReadingStatus.UNSTABLE] * 3
    assert avg.count == 7 and avg.rejected == 3
    kept = np.array([r.point_mm for r in avg.readings if r.accurate])
    np.testing.assert_array_equal(avg.mean_mm, kept.mean(axis=0))
    sim.arm_fault("MEAS+1 inaccurate count=2")
    avg = measure_average(tracker, 4, reject_flagged=False)
    assert avg.count == 4 and [r.status for r in avg.readings][:2] == [ReadingStatus.INACCURATE] * 2


def test_too_few_stable_readings_raise_target_unstable(setup):
    sim, tracker = setup
    sim.arm_fault("MEAS+1 unstable count=6")
    raises_within(TargetUnstable, 10 * LIVE_TIMEOUT_S, measure_average, tracker, 10)


def test_unstable_error_reply_and_busy(setup):
    sim, tracker = setup
    sim.arm_fault("MEAS+1 error code=TARGET_UNSTABLE")
    raises_within(TargetUnstable, LIVE_TIMEOUT_S, tracker.measure)
    sim.arm_fault("MEAS+1 error code=3")
    raises_within(TrackerBusy, LIVE_TIMEOUT_S, tracker.measure)
    assert_recovered(tracker, sim)


def test_tcp_hangup_reconnects_rechecks_identity_and_reapplies_settings(served):
    sim, _, tcp = served
    log = io.StringIO()
    tracker = live_tracker(tcp, record=log)
    tracker.connect(Environment(22.5, 990.0, 35.0), mode="PRECISE")
    sim.arm_fault("MEAS+1 hangup")
    mark = len(log.getvalue().splitlines())
    # Hang-up noticed at once; one reconnect (close, pause, open, 5 exchanges) succeeds.
    err = raises_within(ConnectionLost, CLOSE_S + 0.05 + 5 * LIVE_TIMEOUT_S, tracker.measure)
    assert "not repeated" in str(err)
    after = [json.loads(line) for line in log.getvalue().splitlines()[mark:]]
    sent = [e["data"].split("*")[0].split(",", 1)[1] for e in after if e["dir"] == "tx"]
    # The lost MEAS, then identity, units, environment and mode again, then status: no INIT,
    # and no second MEAS.
    assert sent == ["MEAS", "ID?", "UNITS,MM,RAD", "ENV,22.50,990.00,35.0", "MODE,PRECISE", "STAT?"]
    assert_recovered(tracker, sim)
    tracker.close()


def test_query_survives_a_hangup(served):
    sim, _, tcp = served
    tracker = connected(tcp, reconnect_delay_s=0.05)
    sim.arm_fault("STAT?+1 hangup")
    assert tracker.status().state == "READY"  # idempotent: re-sent once after reconnecting
    tracker.close()


def test_reconnect_to_a_different_tracker_is_refused(served):
    sim, _, tcp = served
    tracker = connected(tcp, reconnect_delay_s=0.05)
    sim.arm_fault("MEAS+1 hangup")
    sim.serial = "SIM-9999"  # someone swapped the tracker behind the same address
    raises_within(IdentityChanged, CLOSE_S + 0.05 + LIVE_TIMEOUT_S, tracker.measure)
    raises_within(IdentityChanged, CLOSE_S + 0.05 + LIVE_TIMEOUT_S, tracker.measure)
    tracker.close()


def test_pty_hangup_is_connection_lost_not_a_hang(served):
    sim, path, _ = served
    tracker = connected(path, reconnect_attempts=2, reconnect_delay_s=0.05)
    sim.arm_fault("MEAS+1 hangup")
    # The pty is gone for good: both reconnect attempts fail at once (nothing to open).
    for _ in range(2):  # still gone, still bounded
        try:
            raises_within(ConnectionLost, 2 * 0.05, tracker.measure)
        except BaseException:
            # Tests run two at a time: the freed pty number can be handed straight to
            # another test's simulator, and the reconnect reaches that device instead.
            if os.path.exists(path):
                pytest.skip(f"{path} was reused by another test before the reconnect")
            raise
    tracker.close()


def test_port_disappears_when_the_simulator_process_dies(sim_process):
    proc, (path,) = sim_process("--pty", "--initialised", "--target", "2000,0,0")
    tracker = connected(path, reconnect_attempts=2, reconnect_delay_s=0.05)
    assert tracker.measure().accurate
    proc.kill()
    proc.wait(timeout=5)
    raises_within(ConnectionLost, 2 * 0.05, tracker.measure)
    tracker.close()


def test_tcp_server_gone_is_connection_lost(sim_process):
    proc, (port,) = sim_process("--tcp", "0", "--initialised", "--target", "2000,0,0")
    tracker = connected(f"socket://127.0.0.1:{port}", reconnect_attempts=2, reconnect_delay_s=0.05)
    assert tracker.measure().accurate
    proc.terminate()
    proc.wait(timeout=5)
    raises_within(ConnectionLost, 2 * (CLOSE_S + 0.05), tracker.measure)
    tracker.close()
