"""N readings of one pose reduced to mean, spread and count (what the measure loop records).

Domain logic over the :class:`~calibrator.acquire.ports.Tracker` port: any
tracker brand's readings average the same way, through one rule:

1. **Flagged** readings (the tracker says inaccurate or unstable) and
   readings with a non-finite coordinate (or one beyond 1 km) are left out.
2. **Outliers** are left out by a per-axis Hampel rule: a reading is an
   outlier when, on any axis, it lies more than :data:`OUTLIER_Z` (3.5) robust
   standard deviations from the median of the set, the robust standard
   deviation being ``1.4826 * MAD`` (median absolute deviation, consistent
   with a Gaussian sigma) **floored by the tracker's stated accuracy** at that
   range (:class:`StatedAccuracy`). The floor matters: a quiet tracker gives a
   MAD of a micrometre or less, and without it good readings a few micrometres
   off would be thrown away.
3. **Too few left** (fewer than ``min_count``): :class:`TooFewReadings`; the
   measure loop takes the whole set again (a set is never topped up: every
   recorded pose is the mean of one uninterrupted set).
4. **Spread limit**: if the accepted readings' standard deviation on any axis
   exceeds ``max_spread_mm`` (default three times the stated accuracy), the
   target moved or the set is split in two: :class:`UnstablePose`. The pose is
   never recorded silently; the loop measures it again and journals why.

Every one of these outcomes is named in :attr:`AveragedReading.notes` or in
the error's message.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from calibrator.acquire.ports import BadReading, ReadingLost, Tracker, TrackerReading
from calibrator.model import rotations

OUTLIER_Z = 3.5  # Iglewicz & Hoaglin's cut-off for the MAD-based modified z-score
MAD_TO_SIGMA = 1.4826  # 1 / Phi^-1(3/4): MAD of a Gaussian times this is its sigma
SPREAD_OVER_ACCURACY = 3.0  # default spread limit, in stated accuracies
MAX_COORDINATE_MM = 1e6  # 1 km: no tracker reads beyond; 1e300 is a corrupt value, not a point


class SetRejected(ReadingLost):
    """The readings of one pose do not make a trustworthy mean; measure the pose again."""


class TooFewReadings(SetRejected):
    """Fewer readings than needed were accepted (the rest flagged or outliers)."""


class ImpossibleReadings(TooFewReadings, BadReading):
    """Too few readings were accepted because the rest held numbers no tracker reads."""


class UnstablePose(SetRejected):
    """The accepted readings spread more than the limit: the target was not still."""


@dataclass(frozen=True)
class StatedAccuracy:
    """A tracker's stated 1-sigma point accuracy, ``const_mm + per_m_mm * range``.

    The default is a Leica AT9xx-class absolute tracker (15 um + 6 um/m MPE,
    taken as the floor of sigma: a conservative floor rejects fewer good readings).

    Attributes
    ----------
    const_mm : float
        Range-independent part, mm.
    per_m_mm : float
        Part growing with the range from the tracker, mm per metre.
    """

    const_mm: float = 0.015
    per_m_mm: float = 0.006

    def at(self, range_mm: float) -> float:
        """Stated accuracy (mm) at ``range_mm`` from the tracker."""
        return self.const_mm + self.per_m_mm * range_mm / 1000.0


DEFAULT_ACCURACY = StatedAccuracy()


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
        Readings left out (flagged, non-finite or outliers).
    rotvec_mean_rad : numpy.ndarray, shape (3,), or None
        Mean probe orientation (rotation vector, rad) for a 6-DoF probe.
    rotvec_std_rad : numpy.ndarray, shape (3,), or None
        Spread of the orientations about that mean (rotation vectors, ddof=1), rad.
    readings : tuple
        Every reading taken, accepted or not, in order.
    outliers : int
        Of ``rejected``, those left out by the outlier rule.
    notes : tuple of str
        Why readings were left out (empty when none were).
    """

    mean_mm: np.ndarray
    std_mm: np.ndarray
    count: int
    rejected: int
    rotvec_mean_rad: np.ndarray | None
    rotvec_std_rad: np.ndarray | None
    readings: tuple
    outliers: int = 0
    notes: tuple[str, ...] = ()


def inlier_mask(points_mm: np.ndarray, accuracy: StatedAccuracy = DEFAULT_ACCURACY) -> np.ndarray:
    """Readings the outlier rule keeps (see the module docstring).

    Parameters
    ----------
    points_mm : numpy.ndarray, shape (N, 3)
        Finite positions, tracker frame (tracker at the origin), mm.
    accuracy : StatedAccuracy
        Floor of the robust sigma, evaluated at the median's range.

    Returns
    -------
    numpy.ndarray of bool, shape (N,)
    """
    points = np.asarray(points_mm, dtype=float).reshape(-1, 3)
    if len(points) == 0:
        return np.zeros(0, dtype=bool)
    median = np.median(points, axis=0)
    dev = np.abs(points - median)
    floor = accuracy.at(float(np.linalg.norm(median)))
    sigma = np.maximum(MAD_TO_SIGMA * np.median(dev, axis=0), floor)
    return np.all(dev <= OUTLIER_Z * sigma, axis=1)


def average(
    readings: Sequence[TrackerReading],
    *,
    reject_flagged: bool = True,
    min_count: int | None = None,
    accuracy: StatedAccuracy = DEFAULT_ACCURACY,
    max_spread_mm: float | str | None = None,
) -> AveragedReading:
    """Average a finished set of readings (see :func:`measure_average` and the module rule).

    ``max_spread_mm``: a limit in mm, ``"stated"`` (three times ``accuracy`` at
    the mean's range) or None, the default here: no limit, since the limit is
    an acquisition decision, which :func:`measure_average` makes by default.

    Raises
    ------
    TooFewReadings
        Fewer than ``min_count`` readings were accepted.
    ImpossibleReadings
        Too few were accepted because the rest held impossible numbers
        (NaN, infinite, beyond 1 km): a :class:`TooFewReadings` and a
        :class:`~calibrator.acquire.ports.BadReading`, named for that.
    UnstablePose
        The accepted readings spread more than ``max_spread_mm`` on some axis.
    """
    readings = tuple(readings)
    n = len(readings)
    min_count = -(-n // 2) if min_count is None else min_count
    usable, outliers, why = _select(readings, reject_flagged, accuracy)
    count = int(usable.sum())
    if count < max(min_count, 1):
        message = f"only {count} of {n} readings usable, need {min_count}{why}"
        if outliers == 0 and "non-finite" in why and "flagged" not in why:
            # Emptied by numbers no tracker can read: name that, not the count.
            raise ImpossibleReadings(f"reading with impossible numbers: {message}")
        raise TooFewReadings(message)
    accepted = [r for r, keep in zip(readings, usable, strict=True) if keep]
    points = np.array([r.point_mm for r in accepted], dtype=float)
    ddof = 1 if count > 1 else 0
    std = points.std(axis=0, ddof=ddof)
    mean = points.mean(axis=0)
    if max_spread_mm == "stated":
        limit = SPREAD_OVER_ACCURACY * accuracy.at(float(np.linalg.norm(mean)))
    else:
        limit = np.inf if max_spread_mm is None else float(max_spread_mm)
    if np.any(std > limit):
        raise UnstablePose(
            f"spread {np.max(std):.4f} mm over {count} readings exceeds the limit "
            f"{limit:.4f} mm (target not still){why}"
        )
    rot_mean = rot_std = None
    if accepted[0].rotvec_rad is not None:
        rots = rotations.rotvec_to_matrix(np.array([r.rotvec_rad for r in accepted]))
        mean_rot = _chordal_mean(rots)
        rot_mean = rotations.matrix_to_rotvec(mean_rot)
        deviations = rotations.matrix_to_rotvec(mean_rot.T @ rots)  # in the mean's frame
        rot_std = deviations.std(axis=0, ddof=ddof)
    return AveragedReading(
        mean_mm=mean,
        std_mm=std,
        count=count,
        rejected=n - count,
        rotvec_mean_rad=rot_mean,
        rotvec_std_rad=rot_std,
        readings=readings,
        outliers=outliers,
        notes=(why.removeprefix("; "),) if why else (),
    )


def _select(
    readings: tuple, reject_flagged: bool, accuracy: StatedAccuracy
) -> tuple[np.ndarray, int, str]:
    """``(usable mask, outlier count, "; why" or "")`` over a set of readings."""
    n = len(readings)
    points = np.array([np.asarray(r.point_mm, dtype=float) for r in readings]).reshape(n, 3)
    with np.errstate(invalid="ignore"):  # NaN compares False: not finite either
        finite = np.all(np.abs(points) <= MAX_COORDINATE_MM, axis=1)
    if reject_flagged:
        flagged = np.array([not r.accurate for r in readings], dtype=bool).reshape(n)
    else:
        flagged = np.zeros(n, dtype=bool)
    candidate = finite & ~flagged
    usable = candidate.copy()
    usable[candidate] = inlier_mask(points[candidate], accuracy)
    outliers = int(candidate.sum() - usable.sum())
    parts = []
    if flagged.any():
        parts.append(f"{int(flagged.sum())} flagged by the tracker")
    if (~finite & ~flagged).any():
        parts.append(f"{int((~finite & ~flagged).sum())} non-finite or beyond 1 km")
    if outliers:
        parts.append(f"{outliers} outlier(s) beyond {OUTLIER_Z} robust sigma of the median")
    return usable, outliers, ("; " + ", ".join(parts)) if parts else ""


def _chordal_mean(rotations: np.ndarray) -> np.ndarray:
    """Rotation nearest (Frobenius) to the mean of rotations (N, 3, 3): the chordal L2 mean.

    Projects the arithmetic mean onto SO(3) with an SVD (the sign fix keeps a
    proper rotation); for a probe's small spread it equals the geodesic mean
    to far below the tracker's angular noise.
    """
    u, _, vt = np.linalg.svd(np.mean(rotations, axis=0))
    return u @ np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))]) @ vt


def measure_average(
    tracker: Tracker,
    n: int = 10,
    *,
    reject_flagged: bool = True,
    min_count: int | None = None,
    accuracy: StatedAccuracy = DEFAULT_ACCURACY,
    max_spread_mm: float | str | None = "stated",
) -> AveragedReading:
    """Take ``n`` single readings and average the accepted ones (module rule).

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
    accuracy : StatedAccuracy
        The tracker's stated accuracy: floor of the outlier rule's sigma.
    max_spread_mm : float, "stated" or None
        Largest per-axis standard deviation of the accepted readings, mm;
        ``"stated"`` (default): three times ``accuracy`` at the readings' median
        range; None: no limit.
    Raises
    ------
    ReadingLost
        From the tracker (beam broken, timeout, ...) before any mean exists:
        no partial average is ever returned; the caller measures the pose again.
    TooFewReadings
        Fewer than ``min_count`` readings were accepted.
    UnstablePose
        The accepted readings spread more than ``max_spread_mm``.
    """
    if n < 1:
        raise ValueError(f"n must be >= 1, got {n}")
    return average(
        [tracker.measure() for _ in range(n)],
        reject_flagged=reject_flagged,
        min_count=min_count,
        accuracy=accuracy,
        max_spread_mm=max_spread_mm,
    )
