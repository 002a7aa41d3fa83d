"""The path test on an arm that runs its own program: tracker-only, from the programmed path.

An external (other-brand) controller runs the program ``calibrator program
--path`` wrote: a hold at the path's start, then per cycle the path at the
stated speed and a hold at its end (an open path also moves back and holds).
Nothing tells the run when the operator starts it, so the tracker streams
until it has seen the cycles:

1. the stream is cut into **motions** (:func:`motions`): runs of samples
   moving faster than :func:`moving_threshold_mm_s` over a
   :data:`calibrator.verify.path.SPEED_STEP` chord, a pause shorter than
   :data:`MERGE_S` (an exact stop at a rectangle's corner) joined;
2. a motion is a **cycle of the test** when it starts within
   :data:`ENDS_MM` of the commanded path's start and ends as near its end
   (a line's way back starts at the end: not a cycle), and lasts between
   half and three times the commanded path's duration at the stated speed;
3. each cycle is **aligned** with the commanded path run at the stated
   speed (:func:`calibrator.verify.path_figures.estimate_latency` on the
   cycle and the holds around it, no robot stream): its times count from
   the start found; the stream is kept from the motion's first moving
   sample to its last (a program stopping at corners runs longer than the
   path at constant speed: a fitted start can fall after the path's first
   calculated points).

The figures are then those of the simulated cell's path test
(:func:`calibrator.verify.path.figures`). Units: mm, s.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import pandas as pd

from calibrator.errors import CalibrationError
from calibrator.verify import path as verify_path
from calibrator.verify import path_figures as ip

#: A pause in the motion shorter than this joins the motions either side (an exact stop at a
#: corner), s; the program's holds are longer (:data:`MIN_HOLD_S`).
MERGE_S = 0.25
#: The shortest hold a path program makes at the path's ends, s.
MIN_HOLD_S = 0.5
#: How far a cycle's rests may be from the commanded path's start and end, mm (an
#: uncalibrated arm misses by a few mm).
ENDS_MM = 20.0
#: Slowest speed counted as motion, mm/s, and the part of the path speed above it.
MIN_MOVING_MM_S = 5.0
MOVING_FRACTION = 0.05
#: Samples read from the stream at a time.
CHUNK = 250
#: Rest looked at before and after a motion for its end positions, s.
REST_S = 0.2


@dataclass(frozen=True)
class Motion:
    """A run of moving samples: indices into the stream and the rests either side.

    Attributes
    ----------
    first, last : int
        Its first and last moving sample.
    start_mm, end_mm : ndarray, shape (3,)
        Median positions of the rests before and after it, mm.
    ended : bool
        The rest after it has been seen for :data:`REST_S`.
    """

    first: int
    last: int
    start_mm: np.ndarray
    end_mm: np.ndarray
    ended: bool


def moving_threshold_mm_s(speed_mm_s: float) -> float:
    """Speed above which the target moves, mm/s: above the tracker's noise, below the path's."""
    return max(MIN_MOVING_MM_S, MOVING_FRACTION * speed_mm_s)


def motions(t_s: npt.ArrayLike, p_mm: npt.ArrayLike, threshold_mm_s: float) -> list[Motion]:
    """The motions of a stream (see the module's step 1).

    Parameters
    ----------
    t_s : array_like, shape (K,)
        Increasing time stamps, s.
    p_mm : array_like, shape (K, 3)
        Positions, mm (finite).
    threshold_mm_s : float

    Returns
    -------
    list of Motion
    """
    t = np.asarray(t_s, dtype=float)
    p = np.asarray(p_mm, dtype=float)
    h = verify_path.SPEED_STEP // 2
    if len(t) < 2 * h + 2:
        return []
    speed = np.zeros(len(t))
    chord = np.linalg.norm(p[2 * h :] - p[: -2 * h], axis=1) / (t[2 * h :] - t[: -2 * h])
    speed[h:-h] = chord
    moving = speed > threshold_mm_s
    idx = np.flatnonzero(moving)
    if not len(idx):
        return []
    # Runs of moving samples, joined across short pauses.
    breaks = np.flatnonzero(t[idx[1:]] - t[idx[:-1]] > MERGE_S)
    firsts = np.concatenate([[idx[0]], idx[breaks + 1]])
    lasts = np.concatenate([idx[breaks], [idx[-1]]])
    out = []
    for first, last in zip(firsts, lasts, strict=True):
        before = (t >= t[first] - REST_S) & (t < t[first]) & ~moving
        after = (t > t[last]) & (t <= t[last] + REST_S) & ~moving
        if not before.any():
            continue  # it began before the stream: its start is unknown
        start = np.median(p[before], axis=0)
        end = np.median(p[after], axis=0) if after.any() else p[last]
        ended = bool(t[-1] - t[last] >= REST_S and after.any())
        out.append(Motion(int(first), int(last), start, end, ended))
    return out


def is_cycle(motion: Motion, t_s: np.ndarray, path: ip.CommandedPath, speed_mm_s: float) -> bool:
    """Whether ``motion`` is a run of the commanded ``path`` (module's step 2)."""
    start, end = path.point(np.array([0.0, path.length_mm]))
    duration = float(t_s[motion.last] - t_s[motion.first])
    expected = path.length_mm / speed_mm_s
    return bool(
        np.linalg.norm(motion.start_mm - start) <= ENDS_MM
        and np.linalg.norm(motion.end_mm - end) <= ENDS_MM
        and 0.5 * expected <= duration <= 3.0 * expected
    )


def align(
    t_s: np.ndarray, p_mm: np.ndarray, motion: Motion, test: verify_path.PathTest
) -> tuple[ip.Stream, float, np.ndarray]:
    """One cycle aligned with the commanded path at the stated speed (module's step 3).

    Returns
    -------
    stream : calibrator.verify.path_figures.Stream
        The motion, base frame, mm, its times from the aligned start (s).
    start : float
        The aligned start less the motion's first moving sample, s.
    keep : ndarray of int
        Indices of the stream's samples kept.
    """
    t0 = float(t_s[motion.first])
    window = (t_s >= t0 - verify_path.HOLD_S) & (t_s <= t_s[motion.last] + verify_path.HOLD_S)
    rel = t_s[window] - t0
    reference = ip.commanded_reference(test.path, test.speed_mm_s)
    start = ip.estimate_latency(rel, p_mm[window], reference, max_latency_s=verify_path.HOLD_S)
    # The whole motion is kept: a program that stops at corners runs longer than the path
    # at constant speed, and a start fitted to it can fall after the first calculated points.
    keep = np.flatnonzero((t_s >= t0) & (t_s <= t_s[motion.last]))
    return ip.Stream(t_s[keep] - t0 - start, p_mm[keep]), float(start), keep


def run(
    tracker: verify_path.PathTracker,
    test: verify_path.PathTest,
    cycles: int,
    tracker2base: npt.ArrayLike,
    *,
    wait_s: float = 600.0,
    say: Callable[[str], None] | None = None,
    clock: Callable[[], float] = time.monotonic,
) -> tuple[dict, pd.DataFrame]:
    """Stream while the arm runs the path program; the figures of its first ``cycles`` cycles.

    Parameters
    ----------
    tracker : PathTracker
    test : calibrator.verify.path.PathTest
        The commanded path and speed (its joints are not used: the controller
        interpolates the program).
    cycles : int
        At least 2.
    tracker2base : array_like, shape (4, 4)
        Registration, mm.
    wait_s : float
        Longest wait for the first cycle's motion and then for each next one, s
        (wall clock): the operator starts the program in it.
    say : callable, optional
        Told once when the stream runs (the moment to start the program).

    Returns
    -------
    section, streams
        As :func:`calibrator.verify.path.run`.

    Raises
    ------
    CalibrationError
        No motion of the path within ``wait_s``, a stream broken or mostly without readings.
    """
    if cycles < 2:
        raise CalibrationError(f"--cycles must be at least 2, got {cycles}")
    t2b = np.asarray(tracker2base, dtype=float)
    threshold = moving_threshold_mm_s(test.speed_mm_s)
    n_all, t_all, p_all, ok_all = [], [], [], []
    found: list[Motion] = []
    deadline = clock() + wait_s
    with tracker.stream(verify_path.STREAM_HZ, None, stall_timeout_s=verify_path.STALL_S) as stream:
        if say is not None:
            say(f"streaming at {verify_path.STREAM_HZ} Hz: start the path program now")
        while True:
            rec = stream.collect(CHUNK)
            if not len(rec.n):
                raise CalibrationError("the tracker ended its stream before the path's cycles")
            n_all.append(rec.n)
            t_all.append(rec.t_us)
            p_all.append(rec.point_mm)
            ok_all.append(rec.code == 0)
            ok = np.concatenate(ok_all)
            t = np.concatenate(t_all)[ok] / 1e6
            p = np.concatenate(p_all)[ok] @ t2b[:3, :3].T + t2b[:3, 3]
            seen = [
                m for m in motions(t, p, threshold) if is_cycle(m, t, test.path, test.speed_mm_s)
            ]
            if len(seen) > len(found):
                deadline = clock() + wait_s  # the program runs: wait for its next cycle afresh
            found = seen
            if len(found) >= cycles and found[cycles - 1].ended:
                break
            if clock() > deadline:
                raise CalibrationError(
                    f"{len(found)} of {cycles} cycles of the {test.shape} seen, then no motion "
                    f"of it for {wait_s:g} s: is the program running, at "
                    f"{test.speed_mm_s:g} mm/s, on this path (same --cube, --tool, --tracker-at)?"
                )
    if ok.sum() < 0.9 * len(ok):
        raise CalibrationError(f"the tracker streamed {int(ok.sum())} readings of {len(ok)} ticks")
    ticks = np.concatenate(n_all)[ok]
    streams, starts, kept = [], [], []
    for motion in found[:cycles]:
        one, start, keep = align(t, p, motion, test)
        streams.append(one)
        starts.append(start)
        kept.append(ticks[keep])
    table = pd.DataFrame(
        {
            "cycle": np.repeat(np.arange(1, cycles + 1), [len(st.t_s) for st in streams]),
            "n": np.concatenate(kept),
            "t_s": np.concatenate([st.t_s for st in streams]),
            **{
                f"{axis}_mm": np.concatenate([st.p_mm[:, k] for st in streams])
                for k, axis in enumerate("xyz")
            },
        },
        columns=list(verify_path.STREAM_COLUMNS),
    )
    section = verify_path.figures(test, streams, starts, cycles)
    section["alignment"] = "tracker only, from the programmed path"
    return section, table
