"""The failures every tracker kind raises, derived from the one tree in :mod:`drivers.errors`.

Each brand (the line protocol, emScon) raises these same classes for the same
failure, so the measure loop, the journal's failure causes and the user read
one name whatever tracker answered; a brand adds a class of its own only for
what no other brand has (emScon's ``UnknownStatus``), derived from one of these.

Which error means what (those the measure loop retries also derive from
:class:`calibrator.acquire.ports.ReadingLost`):

- :class:`TrackerTimeout` -- no complete reply line by the command's deadline.
- :class:`FrameError` / :class:`ChecksumError` -- a reply line that is not a
  valid frame, or whose CRC does not match (both :class:`ProtocolError`).
- :class:`BadReading` -- a well-framed reading whose numbers cannot be true
  (NaN, inf, beyond any tracker's range): the port's
  :class:`calibrator.acquire.ports.BadReading`; the link stays up.
- :class:`TrackerError` -- the tracker answered ``ER``; subclasses name the
  codes the caller acts on (:class:`BeamBroken`, :class:`NotInitialised`,
  :class:`TargetUnstable`, :class:`TrackerBusy`, :class:`FrameRejected`).
- :class:`IdentityChanged` -- after a reconnect a different tracker answered
  (another serial number): the run stops, never mixing two trackers' readings.
- :class:`LinkDropped` -- the port went away during a command and came back:
  the reply is lost (the loop measures again).
- :class:`TrackerGone` -- the port went away and the bounded reconnect did
  not bring it back (the loop ends the run); both are ``ConnectionLost``
  from :mod:`drivers.errors`.
"""

from calibrator.acquire import ports
from calibrator.acquire.ports import BeamLost, ReadingLost, TrackerUnavailable
from drivers.errors import ConnectionLost, DriverError, DriverTimeout, NotReady, ProtocolError

__all__ = [
    "BadReading",
    "BeamBroken",
    "ChecksumError",
    "ConnectionLost",
    "FrameError",
    "FrameRejected",
    "IdentityChanged",
    "LinkDropped",
    "NotInitialised",
    "TargetUnstable",
    "TrackerBusy",
    "TrackerError",
    "TrackerGone",
    "TrackerTimeout",
]


class TrackerTimeout(DriverTimeout, ReadingLost):
    """No complete reply line arrived before the command's deadline."""


class FrameError(ProtocolError, ReadingLost):
    """A received line is not a frame of the tracker protocol (garbled, too long, bad fields)."""


class ChecksumError(FrameError):
    """A received frame's CRC-16 does not match its body."""


class BadReading(FrameError, ports.BadReading):
    """A reading, well framed, whose values cannot be true (non-finite, absurd); re-measure."""


class LinkDropped(ConnectionLost, ReadingLost):
    """The link failed during a command and a reconnect brought it back; that reply is lost."""


class TrackerGone(ConnectionLost, TrackerUnavailable):
    """The link failed and the bounded reconnect did not bring the tracker back."""


class IdentityChanged(TrackerGone):
    """After a reconnect the device reported a different identity than before."""


class TrackerError(DriverError):
    """The tracker replied ``ER,<seq>,<code>,<text>[,detail]``.

    Attributes
    ----------
    code : int
        Numeric error code (see :class:`drivers.tracker.line.protocol.ErrorCode`).
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


class BeamBroken(TrackerError, BeamLost):
    """The laser beam is interrupted or not locked on a target (codes BEAM_BROKEN, NO_TARGET)."""


class NotInitialised(TrackerError, NotReady):
    """The tracker must be initialised (``INIT``) before it measures. Never done automatically."""


class TargetUnstable(TrackerError, ReadingLost):
    """The target moved during a stationary measurement, or too few stable readings were left."""


class TrackerBusy(TrackerError, NotReady):
    """The tracker is busy (e.g. initialising) and refused the command."""


class FrameRejected(TrackerError, ProtocolError):
    """The tracker could not read the frame the host sent (code BAD_FRAME)."""
