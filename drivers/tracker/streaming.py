"""What every tracker's stream of readings shares: its record as arrays, and its surface.

A stream (the line protocol's ``STREAM``, emScon's continuous time mode) is
read tick by tick with ``next()``; :class:`SampleStream` gives every driver's
stream the same iteration, ``collect`` into a :class:`StreamRecord`, and a
``with`` block that stops it (quietly after a failure, so the failure is
what the caller hears about).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from drivers.tracker.errors import DriverError


class Sample(Protocol):
    """One tick: its number, the tracker's clock, the reading or None, and why not."""

    n: int
    device_time_us: int
    reading: Any
    code: int


@dataclass(frozen=True)
class StreamRecord:
    """A stream's ticks as arrays (what :meth:`ReadingStream.collect` returns).

    Attributes
    ----------
    n : ndarray of int, shape (K,)
        Tick numbers, strictly increasing (gaps are lost ticks).
    t_us : ndarray of int, shape (K,)
        Tracker clock at each tick, microseconds.
    point_mm : ndarray, shape (K, 3)
        Positions, tracker frame, mm; NaN at ticks without a reading.
    rotvec_rad : ndarray, shape (K, 3), or None
        Probe orientations (probe to tracker frame), rad, NaN where none;
        None from a reflector.
    code : ndarray of int, shape (K,)
        0 with a reading, else why there is none.
    accurate : ndarray of bool, shape (K,)
        The reading is flagged ``ACC``.
    """

    n: np.ndarray
    t_us: np.ndarray
    point_mm: np.ndarray
    rotvec_rad: np.ndarray | None
    code: np.ndarray
    accurate: np.ndarray


class SampleStream:
    """The surface every driver's stream shares; subclasses give ``next`` and ``stop``."""

    def next(self) -> Any:  # pragma: no cover - every stream defines it
        raise NotImplementedError

    def stop(self) -> None:  # pragma: no cover - every stream defines it
        raise NotImplementedError

    def __iter__(self) -> Iterator[Any]:
        while (sample := self.next()) is not None:
            yield sample

    def collect(self, count: int) -> StreamRecord:
        """Read up to ``count`` ticks (fewer if the stream ends) into arrays."""
        samples = []
        for sample in self:
            samples.append(sample)
            if len(samples) >= count:
                break
        return record(samples)

    def _stop_quietly(self) -> None:
        """Stop after a failure: the failure is what the caller hears about."""
        try:
            self.stop()
        except DriverError:
            pass  # a tracker that cannot stop shows it at its next command

    def __enter__(self) -> Any:
        return self

    def __exit__(self, *exc: object) -> None:
        if exc[0] is None:
            self.stop()
        else:
            self._stop_quietly()


def record(samples: Sequence[Sample]) -> StreamRecord:
    """Arrays of a list of ticks (see :class:`StreamRecord`)."""
    k = len(samples)
    point = np.full((k, 3), np.nan)
    # A reflector's readings (emScon's among them) carry no orientation.
    six_dof = any(getattr(s.reading, "rotvec_rad", None) is not None for s in samples)
    rot = np.full((k, 3), np.nan) if six_dof else None
    accurate = np.zeros(k, dtype=bool)
    for i, s in enumerate(samples):
        if s.reading is not None:
            point[i] = s.reading.point_mm
            accurate[i] = s.reading.accurate
            if rot is not None and getattr(s.reading, "rotvec_rad", None) is not None:
                rot[i] = s.reading.rotvec_rad
    return StreamRecord(
        n=np.array([s.n for s in samples], dtype=np.int64),
        t_us=np.array([s.device_time_us for s in samples], dtype=np.int64),
        point_mm=point,
        rotvec_rad=rot,
        code=np.array([s.code for s in samples], dtype=np.int64),
        accurate=accurate,
    )
