"""Wire-level cases a well-behaved simulator never produces, scripted byte for byte.

A subclass of the simulator answers chosen commands with raw packets; every
other command gets the simulator's normal answer over the real server.
"""

from __future__ import annotations

import numpy as np
import pytest
from emscon_testkit import TARGET_MM

from drivers.tracker.emscon import EmsconTracker
from drivers.tracker.emscon import packets as pk
from drivers.tracker.emscon.errors import FrameError, TrackerTimeout
from drivers.tracker.emscon.simulator import EmsconServer, EmsconSimulator
from drivers.tracker.emscon.simulator.engine import FAULT_NAMES
from drivers.tracker.simulator.engine import Send
from drivers.tracker.simulator.noise import NoiseModel


class ScriptedSimulator(EmsconSimulator):
    """Answers the next commands of a kind with scripted raw packets, one answer per command."""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.scripts: dict[str, list[list[bytes]]] = {}

    def handle_packet(self, data):
        answers = self.scripts.get(FAULT_NAMES.get(pk.parse_uint(data[8:12]), "UNKNOWN"))
        if answers:
            return [Send(p) for p in answers.pop(0)]
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


def _result(values):
    return pk.encode_single_meas_result(values, (0.0, 0.0, 0.0, 0.0), (20.0, 1013.25, 50.0))


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
    with pytest.raises(TrackerTimeout):
        trk.measure(timeout_s=0.3)
    # The stream cannot be re-cut safely: the adapter reconnects before the next reading.
    assert trk._link.broken
    np.testing.assert_array_equal(trk.measure().point_mm, TARGET_MM)
