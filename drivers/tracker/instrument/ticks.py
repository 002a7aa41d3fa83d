"""When a stream's ticks are due: regular on the tracker's clock, whatever the wire.

Both simulator servers keep one :class:`TickSchedule` per streaming
connection and ask their front-end for tick ``n`` at its stamp.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

from drivers.tracker.instrument.outputs import StreamStall

#: Ticks a late server catches up at once; beyond, the ticks due are lost (a gap).
MAX_CATCH_UP_TICKS = 1000


class TickSchedule:
    """The ticks of one stream on one connection.

    Parameters
    ----------
    device_period_s : float
        Time between ticks on the tracker's clock, s.
    device_start_s : float
        The tracker's clock at tick 0, s.
    now : float
        The wall clock (monotonic) at tick 0, s.
    time_scale : float
        How many times faster than the wall clock the tracker's clock runs.
    count : int, optional
        Ticks in all (None: until stopped).
    stream_id : int
        The wire's name for the stream (the line protocol's ``STREAM`` sequence number).
    """

    def __init__(
        self,
        device_period_s: float,
        device_start_s: float,
        now: float,
        time_scale: float = 1.0,
        count: int | None = None,
        stream_id: int = 0,
    ) -> None:
        self.id = stream_id
        self.device_period_s = device_period_s
        self.period_s = device_period_s / time_scale  # on the wall clock
        self.device_start_s = device_start_s
        self.count = count
        self.n = 0  # last tick sent (or lost)
        self.next_due = now + self.period_s

    def stamp_s(self, n: int) -> float:
        """Tracker time of tick ``n``, s."""
        return self.device_start_s + n * self.device_period_s

    def due(self, now: float) -> bool:
        """Whether the next tick is due at wall-clock time ``now``."""
        return self.next_due <= now

    def catch_up(self, now: float) -> None:
        """After a long hiccup, lose the ticks beyond :data:`MAX_CATCH_UP_TICKS`."""
        due_ticks = int((now - self.next_due) / self.period_s) + 1
        if due_ticks > MAX_CATCH_UP_TICKS:
            self.lose(due_ticks - MAX_CATCH_UP_TICKS)

    def advance(self) -> int:
        """Take the next tick; returns its number."""
        self.n += 1
        self.next_due += self.period_s
        return self.n

    def stall(self, delay_s: float) -> None:
        """Silent for ``delay_s`` (wall clock): the ticks due meanwhile are lost."""
        self.lose(int(delay_s / self.period_s))

    def lose(self, ticks: int) -> None:
        self.n += ticks
        self.next_due += ticks * self.period_s

    @property
    def finished(self) -> bool:
        """Whether the stream's ``count`` ticks have been sent."""
        return self.count is not None and self.n >= self.count


@dataclass(frozen=True)
class StreamStart:
    """Start ticking a stream on this connection (after the reply sent before it).

    Attributes
    ----------
    period_s : float
        Time between ticks on the tracker's clock, s.
    count : int or None
        Ticks in all (None: until stopped).
    stream_id : int
        The wire's name for the stream (the line protocol's ``STREAM`` sequence number).
    """

    period_s: float
    count: int | None = None
    stream_id: int = 0


@dataclass(frozen=True)
class StreamStop:
    """End this connection's stream: no tick after the outputs before it."""


class Clocked(Protocol):
    """A front-end as a server sees it when a stream starts."""

    def device_time_s(self) -> float: ...

    @property
    def time_scale(self) -> float: ...


def stream_control(
    out: object, stream: TickSchedule | None, engine: Clocked, now: float
) -> tuple[bool, TickSchedule | None]:
    """Act on one output if it controls a stream: ``(was it, the connection's schedule now)``.

    ``StreamStart`` starts a schedule at wall-clock ``now`` and the engine's
    clock; ``StreamStop`` ends it; ``StreamStall`` silences it for a while
    (the ticks due meanwhile are lost). Anything else is left to the server.
    """
    if isinstance(out, StreamStart):
        device_s = engine.device_time_s()
        scale = engine.time_scale
        return True, TickSchedule(out.period_s, device_s, now, scale, out.count, out.stream_id)
    if isinstance(out, StreamStop):
        return True, None
    if isinstance(out, StreamStall):
        if stream is not None:
            stream.stall(out.delay_s)
        return True, stream
    return False, stream
