"""Lines the line link cannot take whole: empty, garbled, or longer than any frame.

An empty or garbled line is a frame error at once (its bytes counted as
discarded); a line longer than a frame is refused once, then only its last
``MAX_FRAME`` bytes are kept as it goes on arriving, so a reply glued to its
end is still read, and a deadline that passes meanwhile says the link was
skipping such a line.
"""

from __future__ import annotations

import pytest
from tracker_kit import ScriptedTransport, host, trk

from drivers.tracker.errors import FrameError, TrackerTimeout
from drivers.tracker.line.link import Link, LinkCounters
from drivers.tracker.line.protocol import MAX_FRAME

REPLY = "OK,{},READY,1,1,P3,STANDARD"


class Trickle(ScriptedTransport):
    """Hands out at most ``piece`` bytes per read, as a slow serial line does."""

    def __init__(self, pairs, piece=100):
        super().__init__(pairs)
        self.piece = piece

    def read(self, size: int = 1) -> bytes:
        return super().read(min(size, self.piece))


def test_an_empty_line_is_a_frame_error_at_once():
    port = ScriptedTransport([(host(1, "STAT?"), b"\r\n" + trk(REPLY.format(1)))])
    link = Link(port, counters=LinkCounters(discarded_bytes=10))
    with pytest.raises(FrameError):
        link.transact("STAT?", timeout_s=0.5)
    assert link.counters.discarded_bytes == 10 + 2


def test_a_garbled_line_adds_its_bytes_to_the_discarded_count():
    port = ScriptedTransport([(host(1, "STAT?"), b"garbage\r\n")])
    link = Link(port, counters=LinkCounters(discarded_bytes=10))
    with pytest.raises(FrameError):
        link.transact("STAT?", timeout_s=5.0)
    assert link.counters.discarded_bytes == 10 + len(b"garbage\r\n")


def test_an_over_long_line_is_refused_naming_its_first_60_bytes():
    port = Trickle([(host(1, "STAT?"), bytes(range(65, 91)) * 20)])
    with pytest.raises(FrameError) as err:
        Link(port).transact("STAT?", timeout_s=5.0)
    shown = (bytes(range(65, 91)) * 3)[:60]
    assert str(err.value) == f"no line end within {MAX_FRAME} bytes: {shown!r}"


def test_a_reply_glued_to_the_end_of_an_over_long_line_is_read_while_it_trickles_in():
    junk = b"\x7f" * 3 * MAX_FRAME
    pairs = [(host(1, "STAT?"), junk), (host(2, "STAT?"), junk + trk(REPLY.format(2)))]
    port = Trickle(pairs)
    link = Link(port)
    with pytest.raises(FrameError, match="no line end"):
        link.transact("STAT?", timeout_s=5.0)
    assert link.transact("STAT?", timeout_s=5.0).seq == 2
    assert link.counters.discarded_bytes == 6 * MAX_FRAME
    port.verify()


def test_a_deadline_passing_inside_an_over_long_line_says_so():
    pairs = [(host(1, "STAT?"), b"\x7f" * 2 * MAX_FRAME), (host(2, "STAT?"), None)]
    link = Link(Trickle(pairs))
    with pytest.raises(FrameError, match="no line end"):
        link.transact("STAT?", timeout_s=5.0)
    with pytest.raises(TrackerTimeout) as err:
        link.transact("STAT?", timeout_s=0.05)
    assert str(err.value) == (
        f"no reply to STAT? within the deadline ({MAX_FRAME} bytes pending, "
        "skipping a line with no end)"
    )
