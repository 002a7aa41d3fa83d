"""One simulated laser tracker, driven by two wire front-ends.

:class:`Instrument` is the tracker (target, noise, faults, air, warm-up,
latency); :mod:`drivers.tracker.line.simulator` serves it in the product's
line protocol and :mod:`drivers.tracker.emscon.simulator` behind a Leica
emScon server. Fault scripts (:mod:`.faults`), the ``SIM,...`` control
commands (:mod:`.control`), stream tick schedules (:mod:`.ticks`) and the
outputs a front-end hands its server (:mod:`.outputs`) are shared too.
"""

from drivers.tracker.instrument.faults import Fault, FaultSchedule, parse_fault, parse_script
from drivers.tracker.instrument.instrument import (
    MAX_RANGE_MM,
    MAX_WAYPOINTS,
    MIN_RANGE_MM,
    STANDARD_AIR,
    WARM_UP_S,
    Instrument,
    NoiseModel,
    beam_frame,
)
from drivers.tracker.instrument.outputs import HangUp, Output, Send, StreamStall

__all__ = [
    "MAX_RANGE_MM",
    "MAX_WAYPOINTS",
    "MIN_RANGE_MM",
    "STANDARD_AIR",
    "WARM_UP_S",
    "Fault",
    "FaultSchedule",
    "HangUp",
    "Instrument",
    "NoiseModel",
    "Output",
    "Send",
    "StreamStall",
    "beam_frame",
    "parse_fault",
    "parse_script",
]
