"""What one emScon reading is: the ``TrackerReading`` port shape, shared by the stationary
adapter (:mod:`drivers.tracker.emscon.device`) and the continuous stream
(:mod:`drivers.tracker.emscon.stream`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class EmsconReading:
    """One stationary reading (the ``TrackerReading`` port shape).

    Attributes
    ----------
    point_mm : numpy.ndarray, shape (3,)
        Target position (a probe's tip), mm, in the server's frame (normally the
        tracker frame).
    rotvec_rad : numpy.ndarray, shape (3,), or None
        A 6-DoF probe's orientation (probe to server frame) as a rotation vector,
        rad; None for a reflector.
    accurate : bool
        False in emScon's try mode, when ``dStdTotal`` exceeds the adapter's limit,
        or when a probe's rotation status says its 6-DoF values are not valid.
    device_time_us : int
        Host monotonic clock at arrival, us (emScon results carry no time stamp).
    std_mm : numpy.ndarray, shape (4,)
        ``dStd1..3, dStdTotal`` as reported, mm.
    meteo : tuple of float
        Temperature (degC), pressure (hPa), humidity (%) the reading was corrected with.
    """

    point_mm: np.ndarray
    rotvec_rad: np.ndarray | None
    accurate: bool
    device_time_us: int
    std_mm: np.ndarray
    meteo: tuple[float, float, float]
