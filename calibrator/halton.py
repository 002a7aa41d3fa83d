"""Scrambled Halton points, the swarm's quasi-random start (the IPSO paper, section 2.1).

The same construction as ``scipy.stats.qmc.Halton`` (radical inverse in the
first d primes, digits scrambled by random permutations, Owen 2017), written
here because importing ``scipy.stats`` costs about half a second, a third of
the start-up budget of ``calibrator identify``. The unscrambled sequence is
checked against scipy's in the tests.
"""

from __future__ import annotations

import numpy as np


def primes(count: int) -> np.ndarray:
    """The first ``count`` primes."""
    found: list[int] = []
    candidate = 2
    while len(found) < count:
        if all(candidate % p for p in found if p * p <= candidate):
            found.append(candidate)
        candidate += 1
    return np.array(found)


def halton(
    n: int, d: int, rng: np.random.Generator | None = None, scramble: bool = True
) -> np.ndarray:
    """``n`` points of the d-dimensional Halton sequence in [0, 1)^d.

    Parameters
    ----------
    n, d : int
    rng : numpy.random.Generator, optional
        Source of the digit permutations; required when ``scramble``.
    scramble : bool
        Permute the digits of each base at random (one permutation per base
        and digit position), which removes the correlation between high
        dimensions that plain Halton points show.

    Returns
    -------
    ndarray, shape (n, d)
    """
    if scramble and rng is None:
        raise ValueError("a scrambled Halton sequence needs rng")
    index = np.arange(n)
    out = np.zeros((n, d))
    for j, base in enumerate(primes(d)):
        # Enough digits to reach double precision in this base.
        n_digits = int(np.ceil(53 * np.log(2) / np.log(base)))
        rest = index.copy()
        scale = 1.0
        for _ in range(n_digits):
            digit = rest % base
            rest //= base
            scale /= base
            if rng is not None and scramble:
                digit = rng.permutation(base)[digit]

            out[:, j] += digit * scale
            if not scramble and not rest.any():
                break
    return out
