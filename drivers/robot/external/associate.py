"""Which plan pose is each stop? Checked against the nominal arm, never assumed from order.

The program runs the plan in order, but a controller may skip a pose, pause
between two, or dwell twice at one; the tracker only sees where the arm
stops. Each stop is matched to a plan pose in two stages:

1. **Bootstrap (no registration yet).** Distances are frame-free: the tracker
   frame is unknown, but the distance between two stops must equal the
   distance between their poses' nominal tool points (within the tolerance).
   The first three stops whose three pairwise distances fit three poses
   ``i < j < k`` of the plan (at most :data:`BOOTSTRAP_SKIPS` poses skipped
   among them) are assigned; a triangle of distances is far harder to match
   by chance than one distance. Stops before or among them that fit nothing
   are rejected. When several pose triples fit, the one skipping fewest poses
   (then with the smallest distance error) wins.
2. **Registration.** From then on a closed-form registration (Kabsch) of the
   nominal tool points onto the assigned stops, with the tool point itself
   re-estimated once five poses are assigned (the guess from ``--tool`` may be
   off by millimetres), predicts where every later pose should appear in the
   tracker frame. A stop is given the nearest later pose within the
   tolerance, or rejected when none is that close.

A decision waits for the next stop (lag one): when the arm stops twice near
the same pose, the two are compared. Within :data:`SAME_PLACE_MM` of each
other they are one place (the arm settled twice): the later is kept. Else the
stop closer to the prediction is kept when it is clearly closer (by three
times the registration's RMS residual); when it is not, neither is recorded
and the pose is reported missing. So no reading is ever assigned to a pose
the arm merely passed near. Assignments only move forward through the plan; the
poses jumped over are the ones the program skipped.

Units: mm; nominal points in the robot base frame, stops in the tracker frame.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

import numpy as np
from numpy.typing import ArrayLike

from calibrator import frames
from drivers.robot.external.stops import Stop

#: Most poses the bootstrap lets the program have skipped among its first three stops.
BOOTSTRAP_SKIPS = 4
#: Assigned poses from which the tool point is re-estimated with the registration.
TOOL_FIT_POSES = 5
#: Assigned poses from which stops are matched to the registered prediction (before: distances).
REGISTRATION_POSES = 6
#: Two stops closer than this are the same place (the arm settled twice), mm.
SAME_PLACE_MM = 0.5


@dataclass(frozen=True)
class Assigned:
    """A stop recorded as plan pose ``pose``; ``error_mm``: its misfit (distance or prediction)."""

    stop: Stop
    pose: int
    error_mm: float


@dataclass(frozen=True)
class Rejected:
    """A stop that is no plan pose (a pause, an extra stop, the program's start or end pose)."""

    stop: Stop
    reason: str


class Associator:
    """Matches stops (in time order) to plan poses.

    Parameters
    ----------
    flange_poses : array_like, shape (N, 4, 4)
        Nominal flange poses of the plan, robot base frame, mm.
    tool_mm : array_like, shape (3,)
        Guessed reflector position on the flange, mm.
    tolerance_mm : float
        Largest accepted misfit, mm.
    first_pose : int
        Lowest plan row a stop may be (a resumed run starts past its done poses).
    """

    def __init__(
        self, flange_poses: ArrayLike, tool_mm: ArrayLike, tolerance_mm: float, first_pose: int = 0
    ) -> None:
        self.flange = np.asarray(flange_poses, dtype=float)
        self.tool_mm = np.asarray(tool_mm, dtype=float).reshape(3).copy()
        self.tolerance_mm = float(tolerance_mm)
        self.next_pose = int(first_pose)
        self.base2tracker: np.ndarray | None = None
        self.residual_rms_mm = 0.0
        self._unplaced: list[Stop] = []  # bootstrap: stops not yet part of a triangle
        self._pending: Assigned | None = None  # lag one: the last match, not yet final
        self._pairs: list[tuple[int, np.ndarray]] = []  # (pose, stop point) assigned

    # ------------------------------------------------------------ geometry

    def nominal_points(self) -> np.ndarray:
        """Nominal tool points of every plan pose with the current tool estimate, (N, 3), mm."""
        return self.flange[:, :3, :3] @ self.tool_mm + self.flange[:, :3, 3]

    def predicted(self) -> np.ndarray | None:
        """Where each pose should appear, tracker frame, (N, 3), mm; None before registration."""
        if self.base2tracker is None:
            return None
        rot, shift = self.base2tracker[:3, :3], self.base2tracker[:3, 3]
        return self.nominal_points() @ rot.T + shift

    def _register(self) -> None:
        poses = np.array([p for p, _ in self._pairs])
        measured = np.array([m for _, m in self._pairs])
        flange = self.flange[poses]
        fit_tool = len(poses) >= TOOL_FIT_POSES
        for _ in range(20 if fit_tool else 1):
            points = flange[:, :3, :3] @ self.tool_mm + flange[:, :3, 3]
            self.base2tracker = frames.fit_rigid(points, measured)
            if not fit_tool:
                break
            # With the registration fixed the tool point is linear:
            # R (A_k t + b_k) + o = m_k  =>  A_k t = R^T (m_k - o) - b_k.
            rot, shift = self.base2tracker[:3, :3], self.base2tracker[:3, 3]
            rhs = (measured - shift) @ rot - flange[:, :3, 3]
            tool, *_ = np.linalg.lstsq(
                flange[:, :3, :3].reshape(-1, 3), rhs.reshape(-1), rcond=None
            )
            step = np.linalg.norm(tool - self.tool_mm)
            self.tool_mm = tool
            if step < 1e-6:
                break
        points = flange[:, :3, :3] @ self.tool_mm + flange[:, :3, 3]
        fitted = frames.fit_rigid(points, measured)
        self.base2tracker = fitted
        rot, shift = fitted[:3, :3], fitted[:3, 3]
        misfit = np.linalg.norm(points @ rot.T + shift - measured, axis=1)
        self.residual_rms_mm = float(np.sqrt(np.mean(misfit**2)))

    # ------------------------------------------------------------ decisions

    def add(self, stop: Stop) -> list[Assigned | Rejected]:
        """Take one stop; return the decisions now final (about this or earlier stops)."""
        if self.base2tracker is None:
            return self._bootstrap(stop)
        floor = self.next_pose if self._pending is None else self._pending.pose
        if floor >= len(self.flange):
            return [Rejected(stop, "after the last plan pose")]
        errors = self._misfits(stop.point_mm, floor)
        best = int(np.argmin(errors))
        pose, error = floor + best, float(errors[best])
        if error > self.tolerance_mm:
            # A stop far from the last pose of the plan shows the arm has left it.
            last = self._pending is not None and self._pending.pose == len(self.flange) - 1
            out = self._settle() if last else []
            return out + [
                Rejected(
                    stop,
                    f"matches no expected pose: nearest is pose {pose} at {error:.1f} mm "
                    f"(tolerance {self.tolerance_mm:g} mm)",
                )
            ]
        match = Assigned(stop, pose, error)
        if self._pending is not None and self._pending.pose == pose:
            return self._twice(self._pending, match)
        out = self._settle()
        self._pending = match
        return out

    def finish(self) -> list[Assigned | Rejected]:
        """No more stops are coming (for now): make the last match final."""
        if self.base2tracker is None:
            out: list[Assigned | Rejected] = [
                Rejected(s, "too few stops to place (fewer than three fit the plan)")
                for s in self._unplaced
            ]
            self._unplaced = []
            return out
        return self._settle()

    def _misfits(self, point_mm: np.ndarray, floor: int) -> np.ndarray:
        """Misfit of a stop (shape (3,), tracker frame) to every pose from ``floor``, mm.

        With at least :data:`REGISTRATION_POSES` poses assigned: the distance
        to the registered prediction. Before that a registration from three or
        four points extrapolates poorly (a millimetre of model error turns the
        frame by milliradians), so the misfit is the worst disagreement between
        the stop's distances to the assigned stops and the pose's nominal
        distances to their poses: frame-free, like the bootstrap.
        """
        pairs = list(self._pairs)
        if self._pending is not None:
            pairs.append((self._pending.pose, np.asarray(self._pending.stop.point_mm, float)))
        if len(self._pairs) >= REGISTRATION_POSES:
            predicted = self.predicted()
            assert predicted is not None
            return np.linalg.norm(predicted[floor:] - point_mm, axis=1)
        nominal = self.nominal_points()
        poses = np.array([p for p, _ in pairs])
        seen = np.array([m for _, m in pairs])
        measured = np.linalg.norm(seen - point_mm, axis=1)  # (K,)
        expected = np.linalg.norm(nominal[floor:, None, :] - nominal[None, poses, :], axis=2)
        misfit = np.abs(expected - measured[None, :])
        # a pose compared with itself (a second stop there) is no evidence either way
        misfit[poses[None, :] == np.arange(floor, len(nominal))[:, None]] = 0.0
        return misfit.max(axis=1)

    def _twice(self, first: Assigned, second: Assigned) -> list[Assigned | Rejected]:
        """Two stops match one pose: keep the one that is surely it, or neither."""
        pose = first.pose
        apart = float(np.linalg.norm(second.stop.point_mm - first.stop.point_mm))
        if apart <= SAME_PLACE_MM:  # the arm rang or crept and settled again: the later is steadier
            self._pending = second
            return [
                Rejected(first.stop, f"stopped again at pose {pose} (stop {second.stop.number})")
            ]
        keep, drop = sorted((first, second), key=lambda a: a.error_mm)
        if drop.error_mm - keep.error_mm > self.ambiguity_mm():
            self._pending = keep
            return [
                Rejected(
                    drop.stop,
                    f"a second stop near pose {pose}, {drop.error_mm - keep.error_mm:.1f} mm "
                    f"farther than stop {keep.stop.number}",
                )
            ]
        # Both fit about as well: which one is the pose cannot be told, so neither is recorded.
        self._pending = None
        why = f"two stops {apart:.1f} mm apart both fit pose {pose}; neither is recorded"
        return [Rejected(first.stop, why), Rejected(second.stop, why)]

    def ambiguity_mm(self) -> float:
        """How much closer to its prediction a stop must be to win over another, mm.

        Three times the registration's RMS residual (how well the nominal arm
        predicts a stop), at least :data:`SAME_PLACE_MM`.
        """
        return max(3.0 * self.residual_rms_mm, SAME_PLACE_MM)

    def _settle(self) -> list[Assigned | Rejected]:
        if self._pending is None:
            return []
        done, self._pending = self._pending, None
        self._accept(done.pose, done.stop)
        self._register()
        return [done]

    def _accept(self, pose: int, stop: Stop) -> None:
        self._pairs.append((pose, np.asarray(stop.point_mm, dtype=float)))
        self.next_pose = pose + 1

    def _bootstrap(self, stop: Stop) -> list[Assigned | Rejected]:
        self._unplaced.append(stop)
        if len(self._unplaced) < 3:
            return []
        found = self._triangle()
        if found is None:
            return []
        (a, b, c), (i, j, k), error = found
        out: list[Assigned | Rejected] = []
        for n, s in enumerate(self._unplaced[:-1]):
            if n == a:
                out.append(Assigned(s, i, error))
            elif n == b:
                out.append(Assigned(s, j, error))
            else:
                out.append(Rejected(s, "fits no pose of the first three stops' triangle"))
        self._unplaced = []
        self._accept(i, self._unplaced_stop(out, i))
        self._accept(j, self._unplaced_stop(out, j))
        self._pending = Assigned(stop, k, error)
        self._pairs.append((k, np.asarray(stop.point_mm, dtype=float)))
        self._register()
        self._pairs.pop()  # the newest stop stays pending (lag one) like every other
        return out

    @staticmethod
    def _unplaced_stop(out: list, pose: int) -> Stop:
        return next(d.stop for d in out if isinstance(d, Assigned) and d.pose == pose)

    def _triangle(self):
        """Best (stops (a, b, newest), poses (i, j, k), max distance error) or None."""
        stops = np.array([s.point_mm for s in self._unplaced])
        c = len(stops) - 1
        first = self.next_pose
        last = min(len(self.flange), first + 3 + BOOTSTRAP_SKIPS)
        nominal = self.nominal_points()
        best = None
        for a, b in combinations(range(c), 2):
            d_ab = np.linalg.norm(stops[a] - stops[b])
            d_ac = np.linalg.norm(stops[a] - stops[c])
            d_bc = np.linalg.norm(stops[b] - stops[c])
            for i, j, k in combinations(range(first, last), 3):
                error = max(
                    abs(d_ab - np.linalg.norm(nominal[i] - nominal[j])),
                    abs(d_ac - np.linalg.norm(nominal[i] - nominal[k])),
                    abs(d_bc - np.linalg.norm(nominal[j] - nominal[k])),
                )
                if error > self.tolerance_mm:
                    continue
                key = (k - first - 2, error)
                if best is None or key < best[0]:
                    best = (key, (a, b, c), (i, j, k), error)
        return None if best is None else best[1:]
