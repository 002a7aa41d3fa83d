"""The plan type every stage passes: measured poses, vias between them, what it was made for.

A leaf module: it imports nothing of the planner, the cell or the devices, so
any stage (the cell checks, ``measure``, ``program``, ``verify``, a driver)
can hold a :class:`Plan` without pulling in how plans are made.

Joint angles rad, lengths mm, positions in the robot base frame.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from calibrator.errors import CalibrationError


class PlanError(CalibrationError):
    """A plan is invalid (limits, count, file) or cannot be made with these constraints."""


@dataclass(frozen=True)
class PlanOrigin:
    """What a plan was made for: its checks hold for this arm, tracker and tool only.

    Attributes
    ----------
    model : str
        The arm's model name.
    tool_mm : tuple of 3 float
        Reflector position on the flange, mm.
    tracker_at_mm : tuple of 3 float, optional
        Tracker position in the robot base frame, mm; None: the aim was not checked.
    model_sha256 : str, optional
        The description's digest (:attr:`calibrator.robots.RobotDescription.digest`):
        the same name with other kinematics, limits or body is another arm.
    guessed_geometry : str, optional
        What of the arm's collision body was guessed when the plan was checked
        (:attr:`calibrator.robots.Body.guessed`: a URDF's meshes missing);
        None: fitted to the arm's geometry. Its file's ``geometry`` column.
    """

    model: str
    tool_mm: tuple[float, float, float]
    tracker_at_mm: tuple[float, float, float] | None = None
    model_sha256: str | None = None
    guessed_geometry: str | None = None


@dataclass(frozen=True)
class Plan:
    """The whole motion of a run: measured poses in visiting order, and vias between.

    Attributes
    ----------
    q_rad : ndarray, shape (N, 6)
        Measured poses in visiting order, rad; a pose's number is its row.
    via_rad : tuple of N ndarrays, shape (k_i, 6)
        Joint vectors moved through (not measured) before pose i, rad.
    origin : PlanOrigin, optional
        The arm, tracker and tool the plan was made and checked for (plan files
        written by ``calibrator plan`` record it); None: not recorded.
    """

    q_rad: np.ndarray
    via_rad: tuple = ()
    origin: PlanOrigin | None = None

    def __post_init__(self) -> None:
        q = np.asarray(self.q_rad, dtype=float)
        if q.ndim != 2 or q.shape[1] != 6:
            raise PlanError(f"a plan needs 6 joint angles per pose, got shape {q.shape}")
        via = tuple(np.asarray(v, dtype=float).reshape(-1, 6) for v in self.via_rad) or tuple(
            np.zeros((0, 6)) for _ in q
        )
        if len(via) != len(q):
            raise PlanError(f"{len(via)} via lists for {len(q)} poses")
        for array in (q, *via):
            array.setflags(write=False)
        object.__setattr__(self, "q_rad", q)
        object.__setattr__(self, "via_rad", via)

    @property
    def path_rad(self) -> np.ndarray:
        """Every row the robot moves to, vias included, in order, shape (M, 6), rad."""
        rows = [np.vstack([v, q[None]]) for v, q in zip(self.via_rad, self.q_rad, strict=True)]
        return np.vstack(rows) if rows else np.zeros((0, 6))

    @property
    def n_vias(self) -> int:
        """Via rows in the plan."""
        return sum(len(v) for v in self.via_rad)


def digest(q: ArrayLike) -> str:
    """SHA-256 of a plan's joint angles (what ties a journal to its plan)."""
    return hashlib.sha256(np.ascontiguousarray(q, dtype="<f8").tobytes()).hexdigest()


def point(v: ArrayLike) -> tuple[float, float, float]:
    """A point (3,) as a tuple of floats, e.g. a tool or tracker position, mm."""
    x, y, z = (float(c) for c in np.asarray(v, dtype=float).reshape(3))
    return x, y, z


def point_text(v: ArrayLike) -> str:
    """``x,y,z`` as the messages write a point (mm), e.g. ``2500,400,300``."""
    return ",".join(f"{c:g}" for c in np.asarray(v, dtype=float))
