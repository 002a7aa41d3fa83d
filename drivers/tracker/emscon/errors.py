"""emScon result codes mapped onto the drivers' one exception tree.

The adapter reuses the tracker errors of :mod:`drivers.tracker.errors` (so the
measure loop treats both protocols alike); a Leica ``ES_ResultStatus`` picks
the class, and the error keeps the number and Leica's name:

===================================================  =====================================
``ES_RS_MeasurementStatusNotReady`` (10004),          :class:`BeamBroken` (retried: re-measure)
``ES_RS_SystemNotReadyForMeasurement`` (10014)
``ES_RS_NoStationaryResult`` (10009),                 :class:`TargetUnstable` (retried)
``ES_RS_SensorNotStable`` (10013)
``ES_RS_ServerBusy`` (1), ``ES_RS_ADMStartUpBusy``    :class:`TrackerBusy` (a :class:`NotReady`)
``ES_RS_TrackerNotInitialized`` (39)                  :class:`NotInitialised` (never auto-fixed)
``ES_RS_InvalidInputData`` (98)                       :class:`FrameRejected` (the server could
                                                      not read our packet)
any other known code                                  :class:`EmsconRefused`
a code not in the V3.6 header                         :class:`UnknownStatus`
===================================================  =====================================

A well-formed result whose values cannot be a reading (NaN, inf, a coordinate
beyond 1 km or a negative or non-finite standard deviation) is a
:class:`BadReading` (a :class:`FrameError`, so a :class:`ReadingLost`: the pose
is measured again; the link stays up, since the framing held).

Transport failures are those of every tracker kind: :class:`LinkDropped` (a
reconnect worked, the reading in flight is lost: retried), :class:`TrackerGone`
(the reconnects failed: :class:`calibrator.acquire.ports.TrackerUnavailable`)
and :class:`IdentityChanged` (another serial number answered after a reconnect).
Only :class:`EmsconRefused` and :class:`UnknownStatus` are emScon's own.
"""

from __future__ import annotations

from drivers.tracker.emscon.protocol import KNOWN_STATUS, ResultStatus
from drivers.tracker.errors import (
    BadReading,
    BeamBroken,
    ConnectionLost,
    FrameError,
    FrameRejected,
    IdentityChanged,
    LinkDropped,
    NotInitialised,
    TargetUnstable,
    TrackerBusy,
    TrackerError,
    TrackerGone,
    TrackerTimeout,
)

__all__ = [
    "BadReading",
    "BeamBroken",
    "ConnectionLost",
    "EmsconRefused",
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
    "UnknownStatus",
    "error_for_status",
]


class EmsconRefused(TrackerError):
    """The emScon server refused a command with a known code we have no special class for."""


class UnknownStatus(TrackerError):
    """The server answered with a status code that Leica's V3.6 header does not define."""


_BY_STATUS: dict[int, type[TrackerError]] = {
    ResultStatus.MEASUREMENT_STATUS_NOT_READY: BeamBroken,
    ResultStatus.SYSTEM_NOT_READY_FOR_MEASUREMENT: BeamBroken,
    ResultStatus.NO_STATIONARY_RESULT: TargetUnstable,
    ResultStatus.SENSOR_NOT_STABLE: TargetUnstable,
    ResultStatus.SERVER_BUSY: TrackerBusy,
    ResultStatus.ADM_STARTUP_BUSY: TrackerBusy,
    ResultStatus.TRACKER_NOT_INITIALIZED: NotInitialised,
    ResultStatus.INVALID_INPUT_DATA: FrameRejected,
}


def status_name(status: int) -> str:
    """Leica's name for a result status (``ES_RS_...``), or ``UNKNOWN(<n>)``."""
    try:
        return "ES_RS_" + ResultStatus(status).name
    except ValueError:
        return f"ES_RS_{status}" if status in KNOWN_STATUS else f"UNKNOWN({status})"


def error_for_status(status: int, command: str, detail: str = "") -> TrackerError:
    """The typed error for a non-zero ``ES_ResultStatus`` answering ``command``."""
    if status not in KNOWN_STATUS:
        return UnknownStatus(status, status_name(status), detail, command)
    cls = _BY_STATUS.get(status, EmsconRefused)
    return cls(status, status_name(status), detail, command)
