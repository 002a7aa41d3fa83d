"""N readings of one pose reduced to mean, spread and count (what the measure loop records).

Domain logic over the :class:`~calibrator.acquire.ports.Tracker` port: any
tracker brand's readings average the same way.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from calibrator.acquire.ports import ReadingLost


class TooFewReadings(ReadingLost):
    """Fewer readings than needed were accepted (the rest were flagged); measure again."""


@dataclass(frozen=True)
class AveragedReading:
    """Statistics of the accepted readings of one pose, tracker frame.

    Attributes
    ----------
    mean_mm : numpy.ndarray, shape (3,)
        Mean position, mm.
    std_mm : numpy.ndarray, shape (3,)
        Sample standard deviation per axis (ddof=1; zeros when count is 1), mm.
    count : int
        Readings that entered the mean.
    rejected : int
        Readings left out for their status flag.
    rotvec_mean_rad : numpy.ndarray, shape (3,), or None
        Mean probe orientation (rotation vector, rad) for a 6-DoF probe.
    rotvec_std_rad : numpy.ndarray, shape (3,), or None
        Spread of the orientations about that mean (rotation vectors, ddof=1), rad.
    readings : tuple
        Every reading taken, accepted or not, in order.
    """

    mean_mm: np.ndarray
    std_mm: np.ndarray
    count: int
    rejected: int
    rotvec_mean_rad: np.ndarray | None
    rotvec_std_rad: np.ndarray | None
    readings: tuple


def average(readings, *, reject_flagged: bool = True, min_count: int | None = None):
    """Average a finished set of readings (see :func:`measure_average`).

    Raises
    ------
    TooFewReadings
        Fewer than ``min_count`` readings were accepted.
    """
    readings = tuple(readings)
    n = len(readings)
    min_count = -(-n // 2) if min_count is None else min_count
    accepted = [r for r in readings if r.accurate or not reject_flagged]
    if len(accepted) < max(min_count, 1):
        raise TooFewReadings(f"only {len(accepted)} of {n} readings usable, need {min_count}")
    points = np.array([r.point_mm for r in accepted])
    ddof = 1 if len(accepted) > 1 else 0
    rot_mean = rot_std = None
    if accepted[0].rotvec_rad is not None:
        from scipy.spatial.transform import Rotation  # only 6-DoF probes pay for the import

        rots = Rotation.from_rotvec(np.array([r.rotvec_rad for r in accepted]))
        mean_rot = rots.mean()
        rot_mean = mean_rot.as_rotvec()
        rot_std = (mean_rot.inv() * rots).as_rotvec().std(axis=0, ddof=ddof)
    return AveragedReading(
        mean_mm=points.mean(axis=0),
        std_mm=points.std(axis=0, ddof=ddof),
        count=len(accepted),
        rejected=n - len(accepted),
        rotvec_mean_rad=rot_mean,
        rotvec_std_rad=rot_std,
        readings=readings,
    )


def measure_average(
    tracker, n: int = 10, *, reject_flagged: bool = True, min_count: int | None = None
) -> AveragedReading:
    """Take ``n`` single readings and average the accepted ones.

    Parameters
    ----------
    tracker : calibrator.acquire.ports.Tracker
        Anything with ``measure() -> TrackerReading``.
    n : int
        Readings to take (10, the source paper's practice).
    reject_flagged : bool
        Leave readings flagged inaccurate or unstable out of the mean.
    min_count : int, optional
        Fewest accepted readings that make a result; default ``ceil(n / 2)``.

    Raises
    ------
    ReadingLost
        From the tracker (beam broken, timeout, ...) before any mean exists:
        no partial average is ever returned; the caller measures the pose again.
    TooFewReadings
        Fewer than ``min_count`` readings were accepted.
    """
    if n < 1:
        raise ValueError(f"n must be >= 1, got {n}")
    return average(
        [tracker.measure() for _ in range(n)], reject_flagged=reject_flagged, min_count=min_count
    )
