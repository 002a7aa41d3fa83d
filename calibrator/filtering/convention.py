"""Joint values as a controller states them, and as the model reads them.

A controller's joint angles can differ from the kinematic model's by a sign
and a zero offset per joint (and, on some arms, a coupling of joints 2 and 3).
Every joint value the filter reads or writes passes through
:func:`to_model` and :func:`to_controller`, so an arm description that
states its controller's convention plugs in here and nowhere else. The arms
known today (:mod:`calibrator.models`) state their joints as the model does:
both functions are the identity for them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike


@dataclass(frozen=True)
class Convention:
    """A controller's joint convention: ``q_model = sign * q_controller + offset``.

    Attributes
    ----------
    sign : ndarray, shape (6,)
        +1 or -1 per joint.
    offset_rad : ndarray, shape (6,)
        Model angle at the controller's zero (rad).
    """

    sign: np.ndarray = field(default_factory=lambda: np.ones(6))
    offset_rad: np.ndarray = field(default_factory=lambda: np.zeros(6))


#: The convention of every arm in :mod:`calibrator.models`.
IDENTITY = Convention()


def for_model(name: str | None) -> Convention:
    """The controller convention of a model (today: the identity for every known arm)."""
    return IDENTITY


def to_model(q_controller: ArrayLike, convention: Convention = IDENTITY) -> np.ndarray:
    """Controller joint angles (rad), shape (N, 6), to the model's (rad)."""
    q = np.asarray(q_controller, dtype=float)
    return q * convention.sign + convention.offset_rad


def to_controller(q_model: ArrayLike, convention: Convention = IDENTITY) -> np.ndarray:
    """The model's joint angles (rad), shape (N, 6), to the controller's (rad)."""
    q = np.asarray(q_model, dtype=float)
    return (q - convention.offset_rad) * convention.sign
