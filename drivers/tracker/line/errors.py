"""The line protocol's ``ER`` codes mapped onto the failures every tracker kind raises.

The classes are those of :mod:`drivers.tracker.errors` (emScon maps its result
statuses onto the same ones in :mod:`drivers.tracker.emscon.errors`), so the
measure loop reads one name per failure whichever tracker answered:

==========================  ==========================================
``BUSY``                    :class:`TrackerBusy` (a ``NotReady``)
``NOT_INITIALISED``         :class:`NotInitialised` (never auto-fixed)
``NO_TARGET``,              :class:`BeamBroken` (retried: re-measure)
``BEAM_BROKEN``
``TARGET_UNSTABLE``         :class:`TargetUnstable` (retried)
``BAD_FRAME``               :class:`FrameRejected` (the tracker could not read our frame)
any other code              :class:`TrackerError`
==========================  ==========================================
"""

from __future__ import annotations

from drivers.tracker.errors import (
    BeamBroken,
    FrameRejected,
    NotInitialised,
    TargetUnstable,
    TrackerBusy,
    TrackerError,
    TrackerTimeout,
)
from drivers.tracker.line.protocol import ErrorCode, Reply

__all__ = ["StreamStalled", "error_from_reply"]


class StreamStalled(TrackerTimeout):
    """A running stream sent no frame within its stall timeout (the driver then stops it)."""


_ERROR_CLASSES: dict[int, type[TrackerError]] = {
    ErrorCode.BUSY: TrackerBusy,
    ErrorCode.NOT_INITIALISED: NotInitialised,
    ErrorCode.NO_TARGET: BeamBroken,
    ErrorCode.BEAM_BROKEN: BeamBroken,
    ErrorCode.TARGET_UNSTABLE: TargetUnstable,
    ErrorCode.BAD_FRAME: FrameRejected,
}


def error_from_reply(reply: Reply, command: str = "") -> TrackerError:
    """The typed exception for an ``ER`` reply (not raised, returned)."""
    cls = _ERROR_CLASSES.get(reply.code, TrackerError)
    return cls(reply.code, reply.text, reply.detail, command)
