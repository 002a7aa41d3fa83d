"""The line link's handling of frames that are neither replies nor echoes, and cut writes."""

from __future__ import annotations

import pytest
from tracker_kit import CONNECT_PAIRS, ScriptedTransport, expected_exchange, host, trk

from drivers.tracker import LaserTracker
from drivers.tracker.errors import FrameError, TrackerTimeout
from drivers.tracker.line.protocol import TERMINATOR


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
    from drivers.tracker.line.link import _frame_starts

    assert _frame_starts(b"OK,1,xER,2OK,3EV,4OK,") == [6, 10, 14, 18]
    assert _frame_starts(b"xOK,") == [1]
    assert _frame_starts(b"OK,no other tag") == []


class Leftovers(ScriptedTransport):
    """A port with bytes still waiting; ``fail`` makes asking for them a transport error."""

    def __init__(self, waiting: bytes, fail: bool = False):
        super().__init__([])
        self.rx += waiting
        self.fail = fail

    @property
    def in_waiting(self) -> int:
        if self.fail:
            raise OSError("port vanished")
        return len(self.rx)

    def reset_input_buffer(self) -> None:
        self.rx.clear()


def test_discarding_input_counts_buffered_and_waiting_bytes_and_ends_a_skip():
    from drivers.tracker.errors import ConnectionLost
    from drivers.tracker.line.link import Link

    port = Leftovers(b"12345")
    link = Link(port)
    link._buf += b"abc"
    link._skipping = True
    link.counters.discarded_bytes = 7
    link.discard_input()
    assert link.counters.discarded_bytes == 7 + 3 + 5 and not port.rx
    assert link._skipping is False and not link._buf
    broken = Link(Leftovers(b"", fail=True))
    with pytest.raises(ConnectionLost, match="^transport failed: port vanished$"):
        broken.discard_input()


def test_every_later_frame_start_is_found_not_only_the_last():
    from drivers.tracker.line.link import _frame_starts

    assert _frame_starts(b"xOK,OK,OK,OK,") == [1, 4, 7, 10]
