"""The line link's timeouts name their command, echoes count as stale, and a link closes for good.

A timeout message is what an operator reads when a run stops, so it says
which command got no answer; our own frames echoed back (a loopback cable,
a half-duplex adapter) are counted with the stale replies, every one of them;
``close_for_good`` shuts a ``socket://`` transport down at once and closes any
other through its own ``close``.
"""

from __future__ import annotations

import socket

import pytest
import serial
from tracker_kit import ScriptedTransport, host, trk

from drivers.tracker.errors import TrackerTimeout
from drivers.tracker.line.link import Link, LinkCounters, close_for_good


class NotReading(ScriptedTransport):
    """A device that stopped reading: every write times out."""

    write_timeout: float | None = None

    def write(self, data: bytes) -> int:
        raise serial.SerialTimeoutException("Write timeout")


def test_a_write_that_times_out_names_its_command():
    link = Link(NotReading([]))
    with pytest.raises(TrackerTimeout) as err:
        link.transact("MEAS", timeout_s=0.05)
    assert str(err.value) == "could not send MEAS within the deadline: the device is not reading"


def test_a_reply_that_never_comes_names_its_command():
    link = Link(ScriptedTransport([(host(1, "STAT?"), None)]))
    with pytest.raises(TrackerTimeout) as err:
        link.transact("STAT?", timeout_s=0.05)
    assert str(err.value) == "no reply to STAT? within the deadline (0 bytes pending)"


def test_every_echo_of_our_own_frame_is_counted_as_stale():
    frame = host(8, "STAT?")
    port = ScriptedTransport([(frame, frame + frame + trk("OK,8,READY,1,1,P3,STANDARD"))])
    counters = LinkCounters(seq=7, stale_replies=5)  # kept from the links before this one
    link = Link(port, counters=counters)
    assert link.transact("STAT?", timeout_s=1.0).seq == 8
    assert link.stale_replies == 5 + 2
    port.verify()


def test_every_late_reply_to_another_command_is_counted_as_stale():
    late = trk("OK,3,READY,1,1,P3,STANDARD") + trk("OK,6,READY,1,1,P3,STANDARD")
    port = ScriptedTransport([(host(8, "STAT?"), late + trk("OK,8,READY,1,1,P3,STANDARD"))])
    link = Link(port, counters=LinkCounters(seq=7, stale_replies=5))
    assert link.transact("STAT?", timeout_s=1.0).seq == 8
    assert link.stale_replies == 5 + 2
    port.verify()


@pytest.fixture
def server():
    listener = socket.create_server(("127.0.0.1", 0))
    yield listener
    listener.close()


def test_a_socket_link_closed_for_good_is_shut_down_and_reads_as_closed(server):
    port = serial.serial_for_url(f"socket://127.0.0.1:{server.getsockname()[1]}", timeout=1.0)
    peer, _ = server.accept()
    with peer:
        peer.settimeout(2.0)
        close_for_good(port)
        assert peer.recv(16) == b""  # the tracker side sees the end at once
    assert not port.is_open
    port.close()  # pyserial's own close afterwards finds nothing left to close


def test_closing_a_socket_link_for_good_skips_pyserials_reconnect_pause(server, monkeypatch):
    from serial.urlhandler import protocol_socket

    pauses = []

    class Clock:
        @staticmethod
        def sleep(seconds):
            pauses.append(seconds)

    port = serial.serial_for_url(f"socket://127.0.0.1:{server.getsockname()[1]}", timeout=1.0)
    server.accept()[0].close()
    monkeypatch.setattr(protocol_socket, "time", Clock)
    close_for_good(port)
    assert pauses == [] and not port.is_open
    reopened = serial.serial_for_url(f"socket://127.0.0.1:{server.getsockname()[1]}")
    reopened.close()
    assert pauses == [0.3]  # what close_for_good spares a link that is not reopened


def test_a_socket_link_whose_peer_is_gone_still_closes(server):
    port = serial.serial_for_url(f"socket://127.0.0.1:{server.getsockname()[1]}", timeout=1.0)
    peer, _ = server.accept()
    # the peer resets the connection: shutting our side down then fails with ENOTCONN
    peer.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, b"\x01\x00\x00\x00\x00\x00\x00\x00")
    peer.close()
    with pytest.raises(serial.SerialException):
        port.read(1)  # the reset has arrived
    close_for_good(port)
    assert not port.is_open


def test_any_other_transport_is_closed_through_its_own_close():
    port = serial.serial_for_url("loop://", timeout=0.1)
    close_for_good(port)
    assert not port.is_open
