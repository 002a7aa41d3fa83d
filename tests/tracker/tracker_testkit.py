"""Test helpers: a scripted transport in the expected-protocol style, frame builders.

:class:`ScriptedTransport` stands in for the serial port (not for the
driver): every write must equal the next scripted host frame, its scripted
reply then becomes readable, and :meth:`ScriptedTransport.verify` fails on
unused pairs or on reply bytes the driver never read.
"""

from __future__ import annotations

import contextlib
from pathlib import Path

from drivers.tracker import LaserTracker
from drivers.tracker.protocol import encode_frame

REPO = Path(__file__).resolve().parents[2]


def host(seq: int, *fields: str) -> bytes:
    """A host frame ``<seq>,<fields...>*CRC\\r\\n``."""
    return encode_frame(",".join([str(seq), *fields]))


def trk(body: str) -> bytes:
    """A tracker frame for ``body`` (e.g. ``"OK,1,READY"``)."""
    return encode_frame(body)


class ScriptedTransport:
    """Serial-like fake replaying ``(expected_write, reply)`` pairs.

    Parameters
    ----------
    pairs : list of (bytes, bytes or None)
        The frame the driver must write next, and the bytes that become
        readable after it (None: nothing, as for a dropped reply).
    """

    def __init__(self, pairs):
        self.pairs = list(pairs)
        self.used = 0
        self.rx = bytearray()
        self.timeout: float | None = 1.0
        self.is_open = True

    # -- serial-like surface
    def write(self, data: bytes) -> int:
        assert self.used < len(self.pairs), f"unexpected write {data!r}: all pairs used"
        expected, reply = self.pairs[self.used]
        assert data == expected, f"pair {self.used}: expected {expected!r}, got {data!r}"
        self.used += 1
        if reply:
            self.rx += reply
        return len(data)

    @property
    def in_waiting(self) -> int:
        return len(self.rx)

    def read(self, size: int = 1) -> bytes:
        chunk = bytes(self.rx[:size])
        del self.rx[:size]
        return chunk

    def read_until(self, expected: bytes = b"\n", size: int | None = None) -> bytes:
        end = self.rx.find(expected)
        n = len(self.rx) if end < 0 else end + len(expected)
        if size is not None:
            n = min(n, size)
        return self.read(n)

    def reset_input_buffer(self) -> None:
        assert not self.rx, f"driver discarded unread reply bytes {bytes(self.rx)!r}"

    def close(self) -> None:
        self.is_open = False

    # -- checks
    def verify(self) -> None:
        unused = self.pairs[self.used :]
        assert not unused, f"{len(unused)} scripted pairs unused, next: {unused[0][0]!r}"
        assert not self.rx, f"reply bytes left unread: {bytes(self.rx)!r}"


@contextlib.contextmanager
def expected_exchange(pairs, **tracker_kwargs):
    """Yield a :class:`LaserTracker` on a :class:`ScriptedTransport`; verify it on exit."""
    transport = ScriptedTransport(pairs)
    tracker = LaserTracker(transport, reconnect_attempts=0, **tracker_kwargs)
    yield tracker
    transport.verify()


LIVE_TIMEOUT_S = 10.0
"""Deadline for commands that should succeed against a live simulator. Generous because
it costs nothing when replies come, and the test machine may be heavily loaded."""


def live_tracker(url, **kwargs) -> LaserTracker:
    """A :class:`LaserTracker` for a live simulator, with generous deadlines unless overridden."""
    opts = dict(
        timeout_s=LIVE_TIMEOUT_S,
        measure_timeout_s=LIVE_TIMEOUT_S,
        init_timeout_s=LIVE_TIMEOUT_S,
        reconnect_delay_s=0.05,
    )
    opts.update(kwargs)
    return LaserTracker(url, **opts)


CONNECT_PAIRS = [
    (host(1, "ID?"), trk("OK,1,ACME,AT-X,123,2.1")),
    (host(2, "UNITS", "MM", "RAD"), trk("OK,2,MM,RAD")),
    (host(3, "STAT?"), trk("OK,3,READY,1,1,P3,STANDARD")),
]
"""What :meth:`LaserTracker.connect` exchanges with no environment or mode given."""
