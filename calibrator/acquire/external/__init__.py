"""The external mode: an arm runs the plan as its own program while the tracker watches.

Domain logic over the tracker port only (no robot link, no drivers): when a
stream of readings says the arm stands still (:mod:`.stops`), where the
nominal arm puts each pose in the tracker frame (:mod:`.registration`) and
which plan pose each stop is (:mod:`.associate`). See
``docs/external-robots.md``.
"""

from calibrator.acquire.external.associate import Assigned, Associator, Rejected
from calibrator.acquire.external.stops import Stop, StopDetector, StopOptions

__all__ = [
    "Assigned",
    "Associator",
    "Rejected",
    "Stop",
    "StopDetector",
    "StopOptions",
]
