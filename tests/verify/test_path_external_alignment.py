"""Tracker-only alignment of an external arm's path run: motions, cycles, start found.

A synthetic stream as a controller running a line program makes it: an
approach from elsewhere, a hold, the line P2 -> P4 with a trapezoidal speed
profile, a hold, the way back, a hold, the line again; stamped with a known
delay and tracker-like noise. The cycles are the two runs of the line (not
the approach, not the way back); each is aligned to its true start.
"""

from __future__ import annotations

import numpy as np
import pytest

from calibrator.verify import path_external as pe
from calibrator.verify import path_figures as ip
from calibrator.verify.path import PathTest

SPEED = 200.0
ACCEL = 2000.0
HZ = 500.0
P2, P4 = np.array([400.0, -150.0, 500.0]), np.array([700.0, 150.0, 800.0])


def _straight(a: np.ndarray, b: np.ndarray, t0: float, t: np.ndarray) -> tuple[np.ndarray, float]:
    """Positions (K, 3) of a rest-to-rest move a -> b from t0 (trapezoid), and its end, s."""
    d = float(np.linalg.norm(b - a))
    t_acc = SPEED / ACCEL
    duration = d / SPEED + t_acc
    u = np.clip(t - t0, 0.0, duration)
    s = np.where(
        u < t_acc,
        0.5 * ACCEL * u**2,
        np.where(u <= duration - t_acc, 0.5 * ACCEL * t_acc**2 + SPEED * (u - t_acc),
                 d - 0.5 * ACCEL * (duration - u) ** 2),
    )  # fmt: skip
    return a + np.outer(s / d, b - a), t0 + duration


def stream(delay_s: float, seed: int = 0):
    """The line program's stream: approach, line, back, line; motion starts of the lines."""
    t = np.arange(0.0, 14.5, 1.0 / HZ)
    elsewhere = np.array([550.0, 300.0, 650.0])
    p = np.empty((len(t), 3))
    starts = []
    segments = [(elsewhere, P2, 0.3), (P2, P4, None), (P4, P2, None), (P2, P4, None)]
    here_t = 0.0
    pieces = []
    for a, b, at in segments:
        t0 = at if at is not None else here_t + 0.8  # a 0.8 s hold before each move
        pieces.append((a, b, t0))
        _, here_t = _straight(a, b, t0, t)
    for k, (a, b, t0) in enumerate(pieces):
        end = pieces[k + 1][2] if k + 1 < len(pieces) else np.inf
        mask = (t >= (t0 if k else -np.inf)) & (t < end)
        p[mask] = _straight(a, b, t0, t[mask])[0]
        if a is P2:
            starts.append(t0)
    rng = np.random.default_rng(seed)
    return t + delay_s, p + rng.normal(0.0, 0.01, p.shape), np.array(starts) + delay_s


def test_the_two_runs_of_the_line_are_its_cycles_not_the_approach_nor_the_way_back():
    t, p, starts = stream(0.0)
    found = pe.motions(t, p, pe.moving_threshold_mm_s(SPEED))
    assert len(found) == 4  # approach, line, back, line
    path = ip.line(P2, P4)
    cycles = [m for m in found if pe.is_cycle(m, t, path, SPEED)]
    assert len(cycles) == 2 and all(m.ended for m in cycles)
    # Each starts within a few samples of where the line's motion starts.
    np.testing.assert_allclose([t[m.first] for m in cycles], starts, atol=0.02)


@pytest.mark.parametrize("delay_s", [0.0, 0.137])
def test_each_cycle_is_aligned_with_the_commanded_line_at_the_stated_speed(delay_s):
    t, p, starts = stream(delay_s, seed=1)
    path = ip.line(P2, P4)
    test = PathTest("line", path, np.eye(3), SPEED, np.zeros(2), np.zeros((2, 6)), False)
    cycles = [m for m in pe.motions(t, p, 10.0) if pe.is_cycle(m, t, path, SPEED)]
    for motion, true_start in zip(cycles, starts, strict=True):
        one, start, keep = pe.align(t, p, motion, test)
        # The constant-speed reference meets the trapezoid half its ramp (v / 2a) late.
        aligned = t[motion.first] + start
        assert aligned == pytest.approx(true_start + 0.5 * SPEED / ACCEL, abs=0.005)
        # The kept stream runs the whole line, start to stop.
        assert np.linalg.norm(one.p_mm[0] - P2) < 0.1 and np.linalg.norm(one.p_mm[-1] - P4) < 0.1


def test_a_motion_already_under_way_when_the_stream_starts_is_not_a_cycle():
    t, p, starts = stream(0.0)
    late = t >= starts[0] + 0.5  # the stream starts half-way along the first line
    found = pe.motions(t[late], p[late], 10.0)
    path = ip.line(P2, P4)
    assert len([m for m in found if pe.is_cycle(m, t[late], path, SPEED)]) == 1
