"""Tracker-specific errors, derived from the one tree in :mod:`drivers.errors`.

Which error means what (those the measure loop retries also derive from
:class:`calibrator.acquire.ports.ReadingLost`):

- :class:`TrackerTimeout` -- no complete reply line by the command's deadline.
- :class:`FrameError` / :class:`ChecksumError` -- a reply line that is not a
  valid frame, or whose CRC does not match (both :class:`ProtocolError`).
- :class:`TrackerError` -- the tracker answered ``ER``; subclasses name the
  codes the caller acts on (:class:`BeamBroken`, :class:`NotInitialised`,
  :class:`TargetUnstable`, :class:`TrackerBusy`, :class:`FrameRejected`).
- :class:`IdentityChanged` -- after a reconnect a different tracker answered.
- ``ConnectionLost`` from :mod:`drivers.errors` -- the port went away and the
  bounded reconnect did not bring it back (or the in-flight command was lost).
"""

from calibrator.acquire.ports import ReadingLost
from drivers.errors import ConnectionLost, DriverError, DriverTimeout, NotReady, ProtocolError

__all__ = [
    "BeamBroken",
    "ChecksumError",
    "ConnectionLost",
    "FrameError",
    "FrameRejected",
    "IdentityChanged",
    "NotInitialised",
    "TargetUnstable",
    "TrackerBusy",
    "TrackerError",
    "TrackerTimeout",
]


class TrackerTimeout(DriverTimeout, ReadingLost):
    """No complete reply line arrived before the command's deadline."""


class FrameError(ProtocolError, ReadingLost):
    """A received line is not a frame of the tracker protocol (garbled, too long, bad fields)."""


class ChecksumError(FrameError):
    """A received frame's CRC-16 does not match its body."""


class IdentityChanged(ConnectionLost):
    """After a reconnect the device reported a different identity than before."""


class TrackerError(DriverError):
    """The tracker replied ``ER,<seq>,<code>,<text>[,detail]``.

    Attributes
    ----------
    code : int
        Numeric error code (see :class:`drivers.tracker.protocol.ErrorCode`).
    text : str
        The code's name as sent by the tracker.
    detail : str
        Optional free text from the tracker ("" when absent).
    command : str
        The command that was refused.
    """

    def __init__(self, code: int, text: str, detail: str = "", command: str = ""):
        self.code = code
        self.text = text
        self.detail = detail
        self.command = command
        msg = f"tracker refused {command or 'command'}: {text} (code {code})"
        if detail:
            msg += f": {detail}"
        super().__init__(msg)


class BeamBroken(TrackerError, ReadingLost):
    """The laser beam is interrupted or not locked on a target (codes BEAM_BROKEN, NO_TARGET)."""


class NotInitialised(TrackerError, NotReady):
    """The tracker must be initialised (``INIT``) before it measures. Never done automatically."""


class TargetUnstable(TrackerError, ReadingLost):
    """The target moved during a stationary measurement, or too few stable readings were left."""


class TrackerBusy(TrackerError, NotReady):
    """The tracker is busy (e.g. initialising) and refused the command."""


class FrameRejected(TrackerError, ProtocolError):
    """The tracker could not read the frame the host sent (code BAD_FRAME)."""
