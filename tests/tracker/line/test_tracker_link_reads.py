"""How the line link reads: never more than a frame can hold, with the port's read timeout
bounded by the command's deadline.

While a line builds up, the link asks the port only for the bytes that can
still belong to one frame (``MAX_FRAME + 1`` minus what it holds), so a flood
of junk cannot grow its buffer. The read timeout is set to the time left only
when the port's is longer than that or under half of it (changing it
reconfigures a tty).
"""

from __future__ import annotations

import pytest
from tracker_kit import TIMEOUT_BOUNDS, ScriptedTransport, host, stat_half_second_left, trk

from drivers.tracker.errors import FrameError
from drivers.tracker.line.link import Link
from drivers.tracker.line.protocol import MAX_FRAME

REPLY = "OK,1,READY,1,1,P3,STANDARD"


class Recording(ScriptedTransport):
    """Hands out at most 100 bytes per read; records the sizes asked for and timeouts set."""

    def __init__(self, pairs, timeout):
        self.timeouts_set: list[float | None] = []
        super().__init__(pairs)
        self._timeout = timeout
        self.timeouts_set.clear()  # only what the link sets counts
        self.asked: list[int] = []

    @property
    def timeout(self):
        return self._timeout

    @timeout.setter
    def timeout(self, value):
        self.timeouts_set.append(value)
        self._timeout = value

    def read(self, size: int = 1) -> bytes:
        self.asked.append(size)
        return super().read(min(size, 100))


def test_while_a_line_builds_up_only_what_fits_a_frame_is_read():
    flood = b"\x7f" * 1000
    port = Recording([(host(1, "STAT?"), flood)], timeout=1.0)
    with pytest.raises(FrameError, match="no line end"):
        Link(port).transact("STAT?", timeout_s=1.0)
    assert port.asked == [MAX_FRAME + 1, MAX_FRAME + 1 - 100, MAX_FRAME + 1 - 200]
    assert len(port.rx) == len(flood) - 257  # the rest is still in the port


@pytest.mark.parametrize(("current", "set_to"), TIMEOUT_BOUNDS)
def test_the_read_timeout_is_set_to_the_time_left_only_when_out_of_range(current, set_to):
    port = Recording([(host(1, "STAT?"), trk(REPLY))], timeout=current)
    stat_half_second_left(port)
    assert port.timeouts_set == set_to


class Unannounced(Recording):
    """A port that never says how many bytes wait (``in_waiting`` 0), as some adapters do."""

    def __init__(self, pairs, timeout):
        super().__init__(pairs, timeout)
        self.asked_until: list[int | None] = []

    @property
    def in_waiting(self) -> int:
        return 0

    def read_until(self, expected: bytes = b"\n", size: int | None = None) -> bytes:
        self.asked_until.append(size)
        return super().read_until(expected, size)


def test_a_line_that_has_begun_is_finished_by_a_read_bounded_to_a_frame():
    port = Unannounced([(host(1, "STAT?"), b"\x7f" * 1000)], timeout=1.0)
    with pytest.raises(FrameError, match="no line end"):
        Link(port).transact("STAT?", timeout_s=1.0)
    # one byte starts the line, then read_until for what still fits (the port gives 100)
    assert port.asked_until == [MAX_FRAME, MAX_FRAME - 100, MAX_FRAME - 200]


class Vanishing(ScriptedTransport):
    def read(self, size: int = 1) -> bytes:
        raise OSError("port vanished")


def test_a_port_that_vanishes_while_reading_is_a_lost_connection_saying_so():
    from drivers.tracker.errors import ConnectionLost

    port = Vanishing([(host(1, "STAT?"), trk(REPLY))])
    with pytest.raises(ConnectionLost) as err:
        Link(port).transact("STAT?", timeout_s=0.5)
    assert str(err.value) == "transport failed while reading: port vanished"


def test_a_link_keeps_the_last_256_events():
    events = trk("EV,0,6,BEAM_BROKEN") * 300
    port = ScriptedTransport([(host(1, "STAT?"), events + trk(REPLY))])
    link = Link(port)
    assert link.transact("STAT?", timeout_s=1.0).seq == 1
    assert len(link.events) == 256
    port.verify()
