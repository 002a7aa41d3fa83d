"""The external mode: an arm runs the plan as its own program while the tracker watches.

An acquisition strategy over the tracker port only (no robot link, no
drivers): when a stream of readings says the arm stands still
(:mod:`.stops`), where the nominal arm puts each pose in the tracker frame
(:mod:`.registration`), which plan pose each stop is (:mod:`.associate`),
the watching that finds each pose's stop (:mod:`.watch`) and the strategy a
run picks for an arm running its own program (:mod:`.arm`, :mod:`.watched`).
See ``docs/external-robots.md``.
"""

from calibrator.acquire.external.arm import ExternalOptions, ProgramArm
from calibrator.acquire.external.associate import Assigned, Associator, Rejected
from calibrator.acquire.external.stops import Stop, StopDetector, StopOptions
from calibrator.acquire.external.watch import Missing, PoseMissing, StopWatcher

__all__ = [
    "Assigned",
    "Associator",
    "ExternalOptions",
    "Missing",
    "PoseMissing",
    "ProgramArm",
    "Rejected",
    "Stop",
    "StopDetector",
    "StopOptions",
    "StopWatcher",
]
