"""What every wire front-end of the simulated tracker shares: its instrument and the
in-process control of it (target, motion, faults, clock)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from drivers.tracker.instrument.faults import Fault
from drivers.tracker.instrument.instrument import Instrument, NoiseModel


class FrontEnd:
    """Base of the line protocol's and emScon's simulators.

    Parameters
    ----------
    instrument : Instrument, optional
        Speak for this tracker; None builds one from ``tracker``.
    **tracker
        :class:`Instrument`'s parameters (``seed``, ``noise``, ``faults``,
        ``init_time_s``, ``initialised``, ``clock``, ``air``, ``on_s``,
        ``latency_s``, ``time_scale``), ignored when ``instrument`` is given.
    """

    def __init__(self, instrument: Instrument | None = None, **tracker: Any) -> None:
        self.instrument = instrument if instrument is not None else Instrument(**tracker)
        self._lock = self.instrument.lock  # held over each command

    @property
    def noise(self) -> NoiseModel:
        return self.instrument.noise

    @property
    def initialised(self) -> bool:
        return self.instrument.initialised

    @initialised.setter
    def initialised(self, value: bool) -> None:
        self.instrument.initialised = value

    @property
    def latency_s(self) -> float:
        """How late the stamps are for a moving target, s."""
        return self.instrument.latency_s

    @latency_s.setter
    def latency_s(self, value: float) -> None:
        self.instrument.latency_s = float(value)

    @property
    def time_scale(self) -> float:
        """How many times faster than the wall clock the tracker's clock runs."""
        return self.instrument.time_scale

    @property
    def _target(self) -> np.ndarray | None:
        return self.instrument.target

    def set_target(self, point_mm: ArrayLike, rotvec_rad: ArrayLike | None = None) -> None:
        """Where the target truly is: shape (3,), mm, tracker frame; the probe's rotation
        vector, shape (3,), rad (:meth:`Instrument.set_target`)."""
        self.instrument.set_target(point_mm, rotvec_rad)

    def clear_target(self) -> None:
        """Remove the target (the beam has nothing to lock on)."""
        self.instrument.clear_target()

    def set_motion(self, motion: Callable[[float], ArrayLike] | None) -> None:
        """Move the target along ``motion(t_s)`` of the tracker's clock
        (:meth:`Instrument.set_motion`); None holds it where it is."""
        self.instrument.set_motion(motion)

    def device_time_s(self) -> float:
        """The tracker's clock now, s (its readings carry it)."""
        return self.instrument.device_time_s()

    def arm_fault(self, fault: Fault | str) -> None:
        """Arm one fault (a :class:`Fault` or a fault-script line)."""
        self.instrument.arm_fault(fault)
