"""Move times under the model's caps, the cell time of a plan, and a time-optimal order.

A ``moveJ`` between two joint vectors moves every joint on a trapezoidal
profile (accelerate, cruise, decelerate) and stretches the faster joints so
that all arrive together: the move takes the time of the slowest joint, the
one with the largest travel under a common speed and acceleration cap.

Times in s, angles rad.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike


def trapezoid_time(travel_rad: ArrayLike, speed_rad_s: float, accel_rad_s2: float) -> np.ndarray:
    """Duration of a rest-to-rest trapezoidal (or triangular) profile, s.

    Parameters
    ----------
    travel_rad : array_like, shape (...)
        Absolute joint travel, rad.
    speed_rad_s, accel_rad_s2 : float
        Speed and acceleration caps, rad/s and rad/s^2.
    """
    travel = np.abs(np.asarray(travel_rad, dtype=float))
    # Below v^2/a the joint never reaches the cap: a triangle.
    corner = speed_rad_s**2 / accel_rad_s2
    return np.where(
        travel >= corner,
        travel / speed_rad_s + speed_rad_s / accel_rad_s2,
        2.0 * np.sqrt(travel / accel_rad_s2),
    )


def move_times(qa: ArrayLike, qb: ArrayLike, speed_rad_s: float, accel_rad_s2: float) -> np.ndarray:
    """Time of each ``moveJ`` ``qa -> qb``, the slowest joint leading, s.

    ``qa`` (M, 6) and ``qb`` (M, 6), or (M, 1, 6) and (1, L, 6) for a matrix.
    """
    travel = np.abs(np.asarray(qb, dtype=float) - np.asarray(qa, dtype=float)).max(axis=-1)
    return trapezoid_time(travel, speed_rad_s, accel_rad_s2)


def time_matrix(q: ArrayLike, speed_rad_s: float, accel_rad_s2: float) -> np.ndarray:
    """Move time between every two poses of ``q`` (N, 6), shape (N, N), s."""
    q = np.asarray(q, dtype=float)
    return move_times(q[:, None], q[None], speed_rad_s, accel_rad_s2)


def path_time(times: np.ndarray, order: Sequence[int]) -> float:
    """Total time of visiting ``order`` with the time matrix ``times``, s."""
    idx = np.asarray(order)
    return float(times[idx[:-1], idx[1:]].sum())


def order_poses(
    times: np.ndarray, start: int | None = None, rounds: int | None = None
) -> np.ndarray:
    """An open path through all poses with short total time (a travelling-salesman path).

    Nearest neighbour from every start (or the given one), then 2-opt
    (segment reversals, vectorized per sweep) until no reversal shortens it.
    Forbidden moves carry ``inf`` and are never chosen while another path exists.

    Parameters
    ----------
    times : ndarray, shape (N, N)
        Symmetric move times, s (``inf``: not allowed).
    start : int, optional
        Pose that must come first.
    rounds : int, optional
        Most 2-opt reversals [default: 20 N, at most 2000].

    Returns
    -------
    ndarray of int, shape (N,)
    """
    n = len(times)
    if n <= 2:
        return np.arange(n)
    # A finite stand-in for inf so sums compare (one forbidden move outweighs all allowed).
    finite = times[np.isfinite(times)]
    big = (finite.max(initial=1.0) + 1.0) * n * 10
    cost = np.where(np.isfinite(times), times, big)
    best: np.ndarray | None = None
    best_cost = np.inf
    # Nearest neighbour from up to 20 spread starts: the 2-opt below does the rest.
    starts = (
        [start] if start is not None else np.unique(np.linspace(0, n - 1, min(n, 20)).astype(int))
    )
    for first in starts:
        walk = [int(first)]
        left = np.ones(n, dtype=bool)
        left[first] = False
        for _ in range(n - 1):
            row = np.where(left, cost[walk[-1]], np.inf)
            step = int(np.argmin(row))
            walk.append(step)
            left[step] = False
        total = float(cost[walk[:-1], walk[1:]].sum())
        if total < best_cost:
            best, best_cost = np.array(walk), total
    path: np.ndarray = best if best is not None else np.arange(n)
    lo = 0 if start is None else 1
    for _ in range(min(20 * n, 2000) if rounds is None else rounds):
        # Reversing path[i..j] replaces edges (i-1, i) and (j, j+1) by (i-1, j) and (i, j+1);
        # at the open ends only one edge changes.
        prev = np.concatenate([[-1], path[:-1]])
        nxt = np.concatenate([path[1:], [-1]])
        i, j = np.triu_indices(n, 1)
        keep = i >= lo
        i, j = i[keep], j[keep]
        before = np.where(i > 0, cost[prev[i], path[i]], 0.0) + np.where(
            j < n - 1, cost[path[j], nxt[j]], 0.0
        )
        after = np.where(i > 0, cost[prev[i], path[j]], 0.0) + np.where(
            j < n - 1, cost[path[i], nxt[j]], 0.0
        )
        gain = before - after
        k = int(np.argmax(gain))
        if gain[k] <= 1e-9:
            break
        path = np.concatenate([path[: i[k]], path[i[k] : j[k] + 1][::-1], path[j[k] + 1 :]])
    return path


@dataclass(frozen=True)
class CellTime:
    """Estimated duration of a measuring run, s.

    Attributes
    ----------
    moves_s : float
        All moves (through via poses too), the slowest joint leading.
    settle_s : float
        Settling before each measured pose.
    readings_s : float
        Readings per pose at the tracker's rate.
    """

    moves_s: float
    settle_s: float
    readings_s: float

    @property
    def total_s(self) -> float:
        """Moves, settling and readings together, s."""
        return self.moves_s + self.settle_s + self.readings_s

    def __str__(self) -> str:
        return (
            f"{_clock(self.total_s)} (moves {_clock(self.moves_s)}, "
            f"settle {_clock(self.settle_s)}, readings {_clock(self.readings_s)})"
        )


def _clock(seconds: float) -> str:
    minutes, sec = divmod(int(round(seconds)), 60)
    return f"{minutes} min {sec:02d} s" if minutes else f"{sec} s"


def cell_time(
    path_rad: ArrayLike,
    n_poses: int,
    speed_rad_s: float,
    accel_rad_s2: float,
    *,
    settle_s: float = 0.5,
    readings: int = 10,
    rate_hz: float = 10.0,
) -> CellTime:
    """Estimate a run's time.

    Parameters
    ----------
    path_rad : array_like, shape (M, 6)
        Every joint vector the robot moves through, in order (via poses included).
    n_poses : int
        Poses measured.
    speed_rad_s, accel_rad_s2 : float
        Leading-joint speed and acceleration, rad/s and rad/s^2.
    settle_s : float
        Wait before reading, per measured pose, s.
    readings : int
        Readings averaged per pose.
    rate_hz : float
        The tracker's reading rate, Hz.
    """
    path = np.asarray(path_rad, dtype=float)
    moves = (
        float(move_times(path[:-1], path[1:], speed_rad_s, accel_rad_s2).sum())
        if len(path) > 1
        else 0.0
    )
    return CellTime(moves, n_poses * settle_s, n_poses * readings / rate_hz)
