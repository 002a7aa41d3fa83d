"""A path program, language-free: the ISO 9283 test path as straight and circular moves.

``calibrator program --path`` writes the path ``calibrator verify --path``
commands (a line, a circle or a rectangle in the test cube) as a robot
program any controller runs on its own: a joint move to the path's start,
a hold, then per cycle the path's straight (``line``) and circular
(``circle``: via point and end point) moves at the stated tool speed and a
hold at its end (a line also moves back to its start, and holds there).
The tracker streams the motion; ``verify --path --robot external`` finds
it in the stream and aligns it with the commanded path in time.

Every target is the **flange** (tool 0) in the **controller's base frame**
(the frames :mod:`calibrator.languages.convention` places on the model):
the tool's orientation is constant along the test path, so the flange's
path is the tool's moved by a constant offset, at the same speed, and no
tool needs defining on the controller. Joint values are the controller's
(:attr:`calibrator.languages.spec.ProgramSpec.angles`). Units: mm, s, rad.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from calibrator.errors import CalibrationError
from calibrator.languages.spec import ProgramSpec

#: The move kinds of a path program.
KINDS = ("line", "circle")
#: Slowest and fastest path speed a program is written with, mm/s.
MIN_SPEED_MM_S = 1.0
MAX_SPEED_MM_S = 5000.0
#: Path acceleration the programs state where the language has one, mm/s^2 (KRL ``$ACC.CP``,
#: URScript ``a``): the speed is reached within 10 mm at 200 mm/s.
PATH_ACCEL_MM_S2 = 2000.0
#: Most cycles a program repeats the path.
MAX_CYCLES = 1000


@dataclass(frozen=True)
class PathMove:
    """One move of the path.

    Attributes
    ----------
    kind : {'line', 'circle'}
    end : int
        Index of its end target in :attr:`PathSpec.poses`.
    via : int or None
        A circular move's via (auxiliary, circle) point; None for a line.
    blend : bool
        The motion goes on into the next move without stopping (a circle's
        two arcs meet tangentially); False: an exact stop at ``end``.
    """

    kind: str
    end: int
    via: int | None = None
    blend: bool = False


@dataclass(frozen=True)
class PathSpec:
    """A path program.

    Attributes
    ----------
    joints : ProgramSpec
        The program's name, model, approach speed and acceleration, the
        controller's joint convention and the joint limits; its ``home_rad``
        is the path's start (the joint move before the path goes there).
    shape : str
        ``line``, ``circle`` or ``rectangle``.
    poses : ndarray, shape (K, 4, 4)
        Targets: the flange in the controller's base frame, mm; index 0 is the start.
    q_rad : ndarray, shape (K, 6)
        The model's joints at each target (nominal inverse kinematics): the
        configuration a language states with a Cartesian target.
    moves : tuple of PathMove
        One cycle of the path, from target 0.
    back : tuple of PathMove
        Moves from the path's end back to its start (an open path), not measured.
    speed_mm_s : float
        Tool (and flange) speed along the path.
    accel_mm_s2 : float
        Path acceleration, where the language states one.
    hold_s : float
        Wait at the start and after each cycle, s: the stream sees the arm still.
    cycles : int
        Runs of the path.
    compensated : bool
        The targets are corrected by a calibration: their orientations differ
        slightly, and a move turns the tool from its start's to its end's
        (KRL ``$ORI_TYPE = #VAR``); without, every target has the start's.
    """

    joints: ProgramSpec
    shape: str
    poses: np.ndarray
    q_rad: np.ndarray
    moves: tuple
    back: tuple
    speed_mm_s: float
    accel_mm_s2: float = PATH_ACCEL_MM_S2
    hold_s: float = 2.0
    cycles: int = 10
    compensated: bool = False

    def __post_init__(self) -> None:
        poses = np.asarray(self.poses, dtype=float)
        if poses.ndim != 3 or poses.shape[1:] != (4, 4) or not np.all(np.isfinite(poses)):
            raise CalibrationError(f"path targets need shape (K, 4, 4), got {poses.shape}")
        if np.shape(self.q_rad) != (len(poses), 6):
            raise CalibrationError(f"{np.shape(self.q_rad)} joints for {len(poses)} targets")
        for move in (*self.moves, *self.back):
            if move.kind not in KINDS or not 0 <= move.end < len(poses):
                raise CalibrationError(f"a path move {move} names no target")
            if (move.kind == "circle") != (move.via is not None):
                raise CalibrationError("a circular move, and only it, has a via point")
        if not self.moves:
            raise CalibrationError("a path program needs at least one move")
        if self.joints.mdh is None:
            raise CalibrationError(
                "a path program needs the nominal MDH table (its configurations)"
            )
        if not MIN_SPEED_MM_S <= self.speed_mm_s <= MAX_SPEED_MM_S:
            raise CalibrationError(
                f"path speed {self.speed_mm_s:g} mm/s is not in "
                f"[{MIN_SPEED_MM_S:g}, {MAX_SPEED_MM_S:g}] mm/s"
            )
        if not self.accel_mm_s2 > 0:
            raise CalibrationError(f"path acceleration {self.accel_mm_s2:g} mm/s^2 is not > 0")
        if not 1 <= self.cycles <= MAX_CYCLES:
            raise CalibrationError(f"cycles {self.cycles} not in 1..{MAX_CYCLES}")
        if not 0.0 < self.hold_s <= 600.0:
            raise CalibrationError(f"hold {self.hold_s:g} s is not in (0, 600] s")
        object.__setattr__(self, "poses", poses)
        object.__setattr__(self, "q_rad", np.asarray(self.q_rad, dtype=float))

    @property
    def name(self) -> str:
        return self.joints.name

    @property
    def mdh(self) -> np.ndarray:
        """The nominal MDH table (6, 5) whose configurations the targets state."""
        assert self.joints.mdh is not None  # checked on construction
        return np.asarray(self.joints.mdh, dtype=float)

    def steps(self) -> list[tuple[str, PathMove | None]]:
        """The program after its joint move to the start: ``("move", m)`` and ``("hold", None)``,
        cycle by cycle (a cycle's path, a hold, and for an open path its way back and a hold)."""
        out: list[tuple[str, PathMove | None]] = [("hold", None)]
        for _ in range(self.cycles):
            out += [("move", m) for m in self.moves] + [("hold", None)]
            if self.back:
                out += [("move", m) for m in self.back] + [("hold", None)]
        return out

    def position(self, k: int) -> np.ndarray:
        """Target ``k``'s flange position, controller base frame, shape (3,), mm."""
        return self.poses[k, :3, 3]

    def rotation(self, k: int) -> np.ndarray:
        """Target ``k``'s flange orientation, controller base frame, shape (3, 3)."""
        return self.poses[k, :3, :3]


def arcs(n: int) -> tuple[PathMove, ...]:
    """A full circle as ``n`` circular moves over targets 1 .. 2n - 1 and back to 0, blended.

    Target ``2k + 1`` is arc ``k``'s via point, ``2k + 2`` its end (the last's is 0).
    """
    return tuple(
        PathMove("circle", (2 * k + 2) % (2 * n), via=2 * k + 1, blend=k < n - 1) for k in range(n)
    )


def circle_moves(first: int) -> tuple[PathMove, PathMove]:
    """A full circle as two half-circle moves over targets ``first .. first + 3`` and back to 0.

    No controller takes a full circle in one circular move (its end would be
    its start): the path's start (target 0), a quarter (``first``), the
    half (``first + 1``), three quarters (``first + 2``) and the start again.
    The arcs meet tangentially: the motion blends through the half.
    """
    return (
        PathMove("circle", first + 1, via=first, blend=True),
        PathMove("circle", 0, via=first + 2),
    )
