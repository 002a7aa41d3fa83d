"""The line link's handling of frames that are neither replies nor echoes, and cut writes."""

from __future__ import annotations

import pytest
from tracker_testkit import CONNECT_PAIRS, ScriptedTransport, expected_exchange, host, trk

from drivers.tracker import LaserTracker
from drivers.tracker.errors import FrameError, TrackerTimeout
from drivers.tracker.protocol import TERMINATOR


def test_a_valid_frame_that_is_no_reply_and_no_echo_is_a_frame_error_at_once():
    pairs = [*CONNECT_PAIRS, (host(4, "MEAS"), trk("HELLO"))]
    with expected_exchange(pairs) as tracker:
        tracker.connect()
        with pytest.raises(FrameError, match="HELLO"):
            tracker.link.transact("MEAS", timeout_s=5.0)


class CutShort(ScriptedTransport):
    """Writes only half of the frame at ``cut``; records output-buffer resets."""

    def __init__(self, pairs, cut):
        super().__init__(pairs)
        self.cut, self.resets = cut, 0

    def write(self, data: bytes) -> int:
        if self.used == self.cut:
            self.used += 1
            return len(data) // 2
        return super().write(data)

    def reset_output_buffer(self) -> None:
        self.resets += 1


def test_a_frame_written_in_part_drops_the_queue_and_the_next_line_ends_it():
    stat = "OK,5,READY,1,1,P3,STANDARD"
    pairs = [*CONNECT_PAIRS, (host(4, "MEAS"), None), (TERMINATOR + host(5, "STAT?"), trk(stat))]
    port = CutShort(pairs, cut=3)
    tracker = LaserTracker(port, reconnect_attempts=0)
    tracker.connect()
    with pytest.raises(TrackerTimeout, match="partial write"):
        tracker.link.transact("MEAS", timeout_s=1.0)
    assert port.resets == 1  # what was still queued is dropped
    assert tracker.link.transact("STAT?", timeout_s=1.0).seq == 5
    port.verify()


def test_frame_starts_are_every_tag_after_the_first_byte_in_order():
    from drivers.tracker.link import _frame_starts

    assert _frame_starts(b"OK,1,xER,2OK,3EV,4OK,") == [6, 10, 14, 18]
    assert _frame_starts(b"xOK,") == [1]
    assert _frame_starts(b"OK,no other tag") == []
