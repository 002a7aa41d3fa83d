"""Improved particle swarm optimisation (IPSO, the IPSO paper, section 2).

1. Initial positions and velocities from a scrambled Halton sequence.
2. Velocities by the constriction-factor rule
   ``v <- K (v + c1 r1 (pbest - x) + c2 r2 (gbest - x))`` with
   ``K = 2 / |2 - phi - sqrt(phi^2 - 4 phi)|``, ``phi = c1 + c2 > 4``.
3. Evaluate, update personal and global bests, stop after a fixed number of
   generations.

The whole swarm moves as arrays; the objective takes all particles at once.
"""

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from calibrator.halton import halton

#: Generations whose random numbers are drawn in one call.
_CHUNK = 16


@dataclass(frozen=True)
class PSOResult:
    """Outcome of :func:`ipso`.

    Attributes
    ----------
    x : ndarray, shape (D,)
        Best position found.
    f : float
        Objective there.
    history : ndarray, shape (generations + 1,)
        Best objective after the initial swarm and after each generation.
    """

    x: np.ndarray
    f: float
    history: np.ndarray


def constriction(c1: float, c2: float) -> float:
    """Clerc's constriction factor K for ``phi = c1 + c2 > 4``."""
    phi = c1 + c2
    if phi <= 4:
        raise ValueError(f"c1 + c2 must exceed 4 for the constriction factor, got {phi}")
    return 2.0 / abs(2.0 - phi - np.sqrt(phi * phi - 4.0 * phi))


def ipso(
    objective: Callable[[np.ndarray], np.ndarray],
    lower: ArrayLike,
    upper: ArrayLike,
    *,
    particles: int = 20,
    generations: int = 2000,
    c1: float = 2.05,
    c2: float = 2.05,
    init_fraction: float = 0.25,
    seed: int | np.random.Generator = 0,
    quasi_random: bool = True,
    on_generation: Callable[[int, float], None] | None = None,
) -> PSOResult:
    """Minimise ``objective`` over the box ``[lower, upper]``.

    Parameters
    ----------
    objective : callable
        Maps positions (P, D) to values (P,).
    lower, upper : array_like, shape (D,)
        Search box; positions are kept inside it.
    particles, generations : int
    c1, c2 : float
        Cognitive and social coefficients (the IPSO paper uses 2.05 each).
    init_fraction : float
        The initial swarm fills this fraction of the box around its centre
        (with :meth:`ParameterSpace.bounds` a quarter is the IPSO paper's start,
        +-0.01 rad and +-0.5 mm).
    seed : int or numpy.random.Generator
        Source of the Halton scrambling and of r1, r2.
    quasi_random : bool
        Start from Halton points (IPSO); False starts from pseudo-random
        points, the plain constriction PSO the IPSO paper improves on.
    on_generation : callable, optional
        Called as ``on_generation(generation, best_cost)`` after each
        generation (1-based), e.g. to show progress.

    Returns
    -------
    PSOResult
    """
    lower = np.asarray(lower, dtype=float)
    upper = np.asarray(upper, dtype=float)
    dim = lower.size
    rng = np.random.default_rng(seed)
    centre, half = (upper + lower) / 2, (upper - lower) / 2
    if quasi_random:
        start = halton(particles, 2 * dim, rng) * 2 - 1
    else:
        start = rng.uniform(-1, 1, (particles, 2 * dim))
    x = centre + init_fraction * half * start[:, :dim]
    # Velocities start small and are capped at the half-width: with the
    # constriction factor this only tames the first few generations.
    v_max = half
    v = init_fraction * half * start[:, dim:]
    k = constriction(c1, c2)
    f = objective(x)
    best_x, best_f = x.copy(), f.copy()
    g = int(np.argmin(best_f))
    history = np.empty(generations + 1)
    history[0] = best_f[g]
    # Constants folded once: v <- K v + K c1 r1 (pbest - x) + K c2 r2 (gbest - x).
    kc1, kc2 = k * c1, k * c2
    # Work buffers: the update below allocates nothing per generation (a few
    # microseconds a call at this size, a tenth of a generation's overhead);
    # the products are formed in the same order as written out, so the
    # trajectory is the same to the bit. Both pulls are formed in one array
    # (2, P, D): K c r (bests - x), for the personal bests and the global
    # one. r1, r2 are drawn and scaled for CHUNK generations at a time: the
    # same numbers in the same order as one draw per generation, and exactly
    # as many, so a generator passed in ends in the same state.
    draws = np.empty((_CHUNK, 2, particles, dim))
    rows = [(d, d[0], d[1]) for d in draws]
    gap = np.empty((2, particles, dim))
    to_own, to_global = gap[0], gap[1]
    scale = np.array([kc1, kc2])[:, np.newaxis, np.newaxis]
    neg_v_max = -v_max
    better = np.empty(particles, dtype=bool)
    better_rows = better[:, np.newaxis]
    for gen in range(1, generations + 1):
        i = (gen - 1) % _CHUNK
        if i == 0:
            block = draws[: min(_CHUNK, generations - gen + 1)]
            rng.random(out=block)
            block *= scale  # K c1 r1, K c2 r2
        r, own_pull, global_pull = rows[i]
        np.subtract(best_x, x, out=to_own)
        np.subtract(best_x[g], x, out=to_global)
        r *= gap
        v *= k
        v += own_pull
        v += global_pull
        np.minimum(v, v_max, out=v)
        np.maximum(v, neg_v_max, out=v)
        x += v
        np.minimum(x, upper, out=x)
        np.maximum(x, lower, out=x)
        f = objective(x)
        np.less(f, best_f, out=better)
        np.copyto(best_x, x, where=better_rows)
        np.copyto(best_f, f, where=better)
        g = int(best_f.argmin())
        history[gen] = best_f[g]
        if on_generation is not None:
            on_generation(gen, float(history[gen]))
    return PSOResult(best_x[g].copy(), float(best_f[g]), history)
