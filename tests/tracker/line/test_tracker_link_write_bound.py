"""The line link bounds each write by the command's deadline, touching the port only when needed.

Setting a write timeout reconfigures a tty (a syscall), so the link leaves a
port's timeout alone while it lies between half the time left and the time
left, and sets it to the time left otherwise. A reply glued behind junk that
itself looks like the start of a frame is still found.
"""

from __future__ import annotations

import pytest
from tracker_kit import TIMEOUT_BOUNDS, ScriptedTransport, host, stat_half_second_left, trk

from drivers.tracker.errors import ConnectionLost
from drivers.tracker.line.link import Link

REPLY = "OK,1,READY,1,1,P3,STANDARD"


class WriteTimeoutPort(ScriptedTransport):
    """Records every write timeout the link sets."""

    def __init__(self, pairs, write_timeout):
        super().__init__(pairs)
        self._write_timeout = write_timeout
        self.set_to: list[float | None] = []

    @property
    def write_timeout(self):
        return self._write_timeout

    @write_timeout.setter
    def write_timeout(self, value):
        self.set_to.append(value)
        self._write_timeout = value


@pytest.mark.parametrize(("current", "set_to"), TIMEOUT_BOUNDS)
def test_the_write_timeout_is_set_to_the_time_left_only_when_out_of_range(current, set_to):
    port = WriteTimeoutPort([(host(1, "STAT?"), trk(REPLY))], write_timeout=current)
    stat_half_second_left(port)
    assert port.set_to == set_to


class Vanished(ScriptedTransport):
    def write(self, data: bytes) -> int:
        raise OSError("port vanished")


def test_a_port_that_vanishes_while_writing_is_a_lost_connection_saying_so():
    with pytest.raises(ConnectionLost) as err:
        Link(Vanished([])).transact("MEAS", timeout_s=0.5)
    assert str(err.value) == "transport failed while writing: port vanished"


def test_a_reply_behind_junk_that_starts_like_a_frame_is_still_read():
    junk = b"\x00OK,1,junk"  # a frame tag whose frame never ends: not a reply
    port = ScriptedTransport([(host(1, "STAT?"), junk + trk(REPLY))])
    link = Link(port)
    assert link.transact("STAT?", timeout_s=0.5).fields[0] == "READY"
    assert link.counters.discarded_bytes == len(junk)
    port.verify()
