"""What a simulated tracker's front-end hands its server, whatever the wire.

Both front-ends (the line protocol's and emScon's) answer a command with a
list of these; their servers send the bytes, close the connection or
silence a stream. Each front-end adds its own stream start and stop.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Send:
    """Bytes to send ``delay_s`` after the previous output of the same connection."""

    data: bytes
    delay_s: float = 0.0


@dataclass(frozen=True)
class HangUp:
    """Close the connection without a reply."""


@dataclass(frozen=True)
class StreamStall:
    """The stream falls silent for ``delay_s``; the ticks due meanwhile are lost."""

    delay_s: float


#: A reply or a hang-up (no stream control).
Output = Send | HangUp
