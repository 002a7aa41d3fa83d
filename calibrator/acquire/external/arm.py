"""What ``--robot external`` opens: an arm running the plan as its own program.

There is no link to the arm: nothing to connect, command, stop or confirm.
A run over a :class:`ProgramArm` measures by watching the tracker for its
stops (:class:`calibrator.acquire.external.watched.Watched`) instead of
moving it.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import ClassVar

from calibrator.acquire.external.stops import StopOptions


@dataclass(frozen=True)
class ExternalOptions:
    """How an external run watches (``measure --robot external``'s stop options).

    The readings per stop and the reflector guess are the run's own
    (``RunOptions.readings``, ``RunOptions.tool_mm``).

    Attributes
    ----------
    stops : StopOptions
        Band, window, tolerance and timeout of the stop detection.
    log : callable, optional
        Receives one line per stop decision.
    clock, sleep : callables
        Monotonic clock (s) and sleep of the watching, replaceable in tests.
    """

    stops: StopOptions = field(default_factory=StopOptions)
    log: Callable[[str], None] | None = None
    clock: Callable[[], float] = time.monotonic
    sleep: Callable[[float], None] = time.sleep


@dataclass(frozen=True)
class ProgramArm:
    """An arm that runs the plan as its own program while the tracker watches.

    Attributes
    ----------
    model_name : str
        The nominal arm it is (``device_id`` ``external:MODEL``).
    speed_cap_rad_s : float
        The model's speed ceiling (or ``--max-speed``): a plan run faster is refused.
    options : ExternalOptions
    """

    #: It moves nothing of ours: no confirmation is asked, no motion capability offered.
    capabilities: ClassVar[frozenset[str]] = frozenset()

    model_name: str
    speed_cap_rad_s: float = float("inf")
    options: ExternalOptions = field(default_factory=ExternalOptions)

    @property
    def device_id(self) -> str:
        return f"external:{self.model_name}"

    def connect(self) -> str:
        """Nothing to connect: the arm is not ours."""
        return "external"

    def close(self) -> None:
        """Nothing to close."""
