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
from tracker_testkit import ScriptedTransport, host, trk

from drivers.tracker.errors import FrameError
from drivers.tracker.link import Link
from drivers.tracker.protocol import MAX_FRAME

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


@pytest.mark.parametrize(
    ("current", "set_to"),
    [
        (None, [0.5]),  # no bound yet
        (0.6, [0.5]),  # longer than the time left
        (0.5, []),  # exactly the time left
        (0.4, []),
        (0.25, []),  # exactly half the time left
        (0.24, [0.5]),  # far too short for the time left
    ],
)
def test_the_read_timeout_is_set_to_the_time_left_only_when_out_of_range(current, set_to):
    port = Recording([(host(1, "STAT?"), trk(REPLY))], timeout=current)
    link = Link(port, clock=lambda: 1000.0)  # a stopped clock: 0.5 s left at each read
    assert link.transact("STAT?", timeout_s=0.5).seq == 1
    assert port.timeouts_set == set_to
    port.verify()
