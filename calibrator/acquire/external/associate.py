"""Which plan pose is each stop? Checked against the nominal arm, never assumed from order.

The program runs the plan in order, but a controller may skip a pose, pause
between two, dwell twice at one, or stop somewhere a pose is not; the
tracker only sees where the arm stops. Nothing about the cell is known
beforehand but the nominal arm: the tracker-to-robot registration (the base)
is unknown, the reflector on the flange (the tool) known only to within
:data:`~.registration.TOOL_BOUND_MM` of the ``--tool`` guess. Every stop is
held to the same rule:

**A stop is pose p when the registration fitted to the other stops puts pose
p within the tolerance of it.** The tolerance is :data:`TOLERANCE_FACTOR`
times the RMS leave-one-out misfit of the stops that registration was fitted
to (how far the nominal arm's prediction of a stop it was not fitted to
lands, measured on this very run), at least :data:`TOLERANCE_FLOOR_MM`, at
most the bound ``tolerance_mm`` (``--match-tolerance``: the most the nominal
arm may be off). See :mod:`.registration` for the fit.

1. **Bootstrap.** No registration exists yet. The first
   :data:`BOOTSTRAP_STOPS` stops (or as many as the plan has poses left,
   when fewer) that fit as many poses of the plan, in plan order (at most
   :data:`BOOTSTRAP_SKIPS` poses skipped and :data:`BOOTSTRAP_REJECTS` stops
   rejected among them), are found by a search: pairs of stops must be as
   far apart as their poses (within the bound plus what a tool anywhere
   within its bound changes that distance), every candidate set is
   registered (base and tool fitted) and every one of its stops must pass
   the rule against the registration of the others. Of the sets that pass,
   the one rejecting and skipping fewest wins (then the smallest misfit).
   Stops before or among them that are not in it are rejected.
2. **Registration.** From then on each stop is compared with where the
   registration of the stops recorded so far puts every later pose: it is
   the nearest later pose within the tolerance, or rejected. Base, tool and
   tolerance are refitted after every recorded stop, so the tolerance
   tightens to what the arm shows.

A decision waits for the next stop (lag one): when the arm stops twice near
the same pose, the two are compared. Within :data:`SAME_PLACE_MM` of each
other they are one place (the arm settled twice): the later is kept. Else the
stop closer to the prediction is kept when it is clearly closer (by three
times the registration's RMS misfit); when it is not, neither is recorded
and the pose is reported missing. So no reading is ever assigned to a pose
the arm merely passed near. Assignments only move forward through the plan; the
poses jumped over are the ones the program skipped.

Units: mm; nominal points in the robot base frame, stops in the tracker frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from calibrator.acquire.external.registration import TOOL_BOUND_MM, Registration, register
from calibrator.acquire.external.stops import Stop

#: Fewest stops a registration is fitted to before its leave-one-out misfits set the
#: tolerance (below, the bound does: a handful of nearby stops underestimates the spread).
RULE_STOPS = 8
#: Stops the bootstrap places together before the first decision: each is judged
#: against the registration of the :data:`RULE_STOPS` others.
BOOTSTRAP_STOPS = RULE_STOPS + 1
#: Most poses the program may have skipped among the bootstrap's stops.
BOOTSTRAP_SKIPS = 4
#: Most stops the bootstrap may reject before or among its stops (home, pauses, a wrong stop).
BOOTSTRAP_REJECTS = 4
#: Tolerance = this many times the RMS leave-one-out misfit of the registration's stops.
#: Measured: a good stop lands at most 2.1 of them from its prediction (192 stops of 12
#: simulated cells, from 8 stops on; tests/external/test_association.py -k factor).
TOLERANCE_FACTOR = 4.0
#: The tolerance never goes below this, mm: a reflector re-seated, a stop still settling.
TOLERANCE_FLOOR_MM = 1.0
#: Stops of a bootstrap set (those nearest to failing) judged against a registration
#: refitted without them; the others against the whole set's leave-one-out misfits.
JUDGED_EXACTLY = 3
#: Depths of the bootstrap's search at which a partial set is registered to cut it short
#: (at every depth it costs more fits than it saves; at none a hopeless search runs long).
PRUNE_DEPTHS = (5, 7)
#: Two stops closer than this are the same place (the arm settled twice), mm.
SAME_PLACE_MM = 0.5
#: What to check when the first stops fit no poses of the plan.
_CHECK = (
    "is it the plan the program was made from, the reflector within "
    f"{TOOL_BOUND_MM:g} mm of --tool, the arm within --match-tolerance of nominal?"
)


@dataclass(frozen=True)
class Assigned:
    """A stop recorded as plan pose ``pose``; ``error_mm``: its distance from the prediction."""

    stop: Stop
    pose: int
    error_mm: float


@dataclass(frozen=True)
class Rejected:
    """A stop that is no plan pose (a pause, an extra or a wrong stop, the start or end pose)."""

    stop: Stop
    reason: str


class Associator:
    """Matches stops (in time order) to plan poses.

    Parameters
    ----------
    flange_poses : array_like, shape (N, 4, 4)
        Nominal flange poses of the plan, robot base frame, mm.
    tool_mm : array_like, shape (3,)
        Guessed reflector position on the flange, mm (the fit may move it by
        up to ``tool_bound_mm``).
    tolerance_mm : float
        Bound of the tolerance: the most the nominal arm may be off, mm.
    first_pose : int
        Lowest plan row a stop may be (a resumed run starts past its done poses).
    tool_bound_mm : float
        Largest distance of the reflector from ``tool_mm``, mm.
    """

    def __init__(
        self,
        flange_poses: ArrayLike,
        tool_mm: ArrayLike,
        tolerance_mm: float,
        first_pose: int = 0,
        tool_bound_mm: float = TOOL_BOUND_MM,
    ) -> None:
        self.flange = np.asarray(flange_poses, dtype=float)
        self.tool_guess_mm = np.asarray(tool_mm, dtype=float).reshape(3).copy()
        self.bound_mm = float(tolerance_mm)
        self.tool_bound_mm = float(tool_bound_mm)
        self.next_pose = int(first_pose)
        self.registration: Registration | None = None
        self._unplaced: list[Stop] = []  # bootstrap: stops not placed yet
        self._pending: Assigned | None = None  # lag one: the last match, not yet final
        self._pairs: list[tuple[int, np.ndarray]] = []  # (pose, stop point) recorded

    # ------------------------------------------------------------ geometry

    @property
    def tool_mm(self) -> np.ndarray:
        """Current reflector estimate on the flange, shape (3,), mm."""
        reg = self.registration
        return self.tool_guess_mm if reg is None else reg.tool_mm

    @property
    def residual_rms_mm(self) -> float:
        """RMS misfit of the recorded stops to the registration, mm (0 before it)."""
        return 0.0 if self.registration is None else self.registration.rms_mm

    def predicted(self) -> np.ndarray | None:
        """Where each pose should appear, tracker frame, (N, 3), mm; None before registration."""
        return None if self.registration is None else self.registration.predict(self.flange)

    def tolerance(self, registration: Registration | None = None) -> float:
        """The tolerance the registration (default the current one) holds a stop to, mm.

        :data:`TOLERANCE_FACTOR` times its RMS leave-one-out misfit, within
        ``[TOLERANCE_FLOOR_MM, tolerance_mm]``; the bound before any registration
        and for a registration fitted to fewer than :data:`RULE_STOPS` stops.
        """
        reg = self.registration if registration is None else registration
        if reg is None or len(reg.loo_mm) < RULE_STOPS:
            return self.bound_mm
        scaled = TOLERANCE_FACTOR * reg.loo_rms_mm()
        return float(min(max(scaled, TOLERANCE_FLOOR_MM), self.bound_mm))

    def _register(self) -> None:
        poses = [p for p, _ in self._pairs]
        reg = register(
            self.flange[poses],
            np.array([m for _, m in self._pairs]),
            self.tool_guess_mm,
            self.tool_bound_mm,
            start_mm=self.tool_mm,
        )
        if reg is not None:  # stops that each passed the rule: None only in a degenerate cell
            self.registration = reg

    # ------------------------------------------------------------ decisions

    def add(self, stop: Stop) -> list[Assigned | Rejected]:
        """Take one stop; return the decisions now final (about this or earlier stops)."""
        if self.registration is None:
            self._unplaced.append(stop)
            return self._bootstrap(self.bootstrap_size())
        floor = self.next_pose if self._pending is None else self._pending.pose
        if floor >= len(self.flange):
            return [Rejected(stop, "after the last plan pose")]
        pose, error = self._nearest(stop, floor)
        if error > self.tolerance():
            # A stop far from the last pose of the plan shows the arm has left it.
            last = self._pending is not None and self._pending.pose == len(self.flange) - 1
            out = self._settle() if last else []
            return out + [Rejected(stop, self._no_match(pose, error))]
        match = Assigned(stop, pose, error)
        if self._pending is not None and self._pending.pose == pose:
            return self._twice(self._pending, match)
        out = self._settle()
        self._pending = match
        return out

    def bootstrap_size(self) -> int:
        """Stops the bootstrap places together: :data:`BOOTSTRAP_STOPS`, or the poses left.

        A plan with fewer poses left than :data:`BOOTSTRAP_STOPS` (an 8-pose
        check, a resumed run near its end) is placed as soon as a stop per pose
        has come, not when the program is taken as ended (at least three: the
        fewest a registration is fitted to).
        """
        return max(3, min(BOOTSTRAP_STOPS, len(self.flange) - self.next_pose))

    def finish(self) -> list[Assigned | Rejected]:
        """No more stops are coming (for now): make the last match final.

        Before the bootstrap has placed its stops, the stops seen are placed
        with as many as fit (at least three; below :data:`BOOTSTRAP_STOPS`
        the leave-one-out check is weak, and the bound is what mostly holds).
        """
        if self.registration is None:
            out: list[Assigned | Rejected] = []
            # bootstrap_size() itself was tried as each stop came
            for size in range(min(self.bootstrap_size() - 1, len(self._unplaced)), 2, -1):
                out += self._bootstrap(size)
                if self.registration is not None:
                    return out + self._settle()
            out += [
                Rejected(s, f"too few stops to place (fewer than three fit the plan; {_CHECK})")
                for s in self._unplaced
            ]
            self._unplaced = []
            return out
        return self._settle()

    def _nearest(self, stop: Stop, floor: int) -> tuple[int, float]:
        """The pose from ``floor`` on predicted nearest to ``stop``, and how near, mm."""
        predicted = self.predicted()
        assert predicted is not None
        errors = np.linalg.norm(predicted[floor:] - stop.point_mm, axis=1)
        best = int(np.argmin(errors))
        return floor + best, float(errors[best])

    def _no_match(self, pose: int, error: float) -> str:
        """Why a stop is no pose: the nearest prediction and the tolerance it missed."""
        reg = self.registration
        stops = 0 if reg is None else len(reg.loo_mm)
        rule = f"{TOLERANCE_FACTOR:g} x the leave-one-out RMS of {stops} recorded stops"
        if stops < RULE_STOPS:
            rule = "--match-tolerance"
        elif self.tolerance() >= self.bound_mm:
            rule = f"--match-tolerance, less than {rule}"
        return (
            f"matches no expected pose: nearest is pose {pose} at {error:.1f} mm "
            f"(tolerance {self.tolerance():.1f} mm: {rule})"
        )

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

        Three times the registration's RMS misfit (how well the nominal arm
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

    # ------------------------------------------------------------ bootstrap

    def _bootstrap(self, size: int) -> list[Assigned | Rejected]:
        """Place ``size`` of the unplaced stops if they fit; the decisions (maybe none)."""
        if len(self._unplaced) < size:
            return []
        found = _Search(self, size).best()
        if found is None:
            if len(self._unplaced) < size + BOOTSTRAP_REJECTS:
                return []
            # The oldest stop fits with no set of the others: it is no pose of the plan's start.
            oldest = self._unplaced.pop(0)
            return [Rejected(oldest, f"fits no pose together with the stops after it ({_CHECK})")]
        chosen, self.registration = found
        first_pose, last_stop = self.next_pose, chosen[-1][0]
        placed = dict(chosen)
        out: list[Assigned | Rejected] = []
        unplaced, self._unplaced = self._unplaced, []
        for n, stop in enumerate(unplaced[: last_stop + 1]):
            if n not in placed:
                # Named with the registration of the stops placed (it was fitted without this one).
                pose, error = self._nearest(stop, first_pose)
                why = (
                    self._no_match(pose, error)
                    if error > self.tolerance()
                    else f"near pose {pose} ({error:.1f} mm) but out of order with the stops placed"
                )
                out.append(Rejected(stop, why))
                continue
            pose = placed[n]
            error = float(
                np.linalg.norm(
                    self.registration.predict(self.flange[pose : pose + 1])[0] - stop.point_mm
                )
            )
            if n == last_stop:
                self._pending = Assigned(stop, pose, error)
            else:
                out.append(Assigned(stop, pose, error))
                self._accept(pose, stop)
        self._register()
        for stop in unplaced[last_stop + 1 :]:  # later stops: matched to the registration
            out += self.add(stop)
        return out


class _Search:
    """The bootstrap's search: ``size`` unplaced stops onto plan poses in order.

    Depth first over the stops in time order, each either placed on a later
    pose or left out, with the cost (stops left out + poses skipped) as the
    bound: the cheapest set whose every stop passes the rule wins.
    """

    def __init__(self, assoc: Associator, size: int):
        self.assoc, self.size = assoc, size
        self.points = np.array([s.point_mm for s in assoc._unplaced])
        self.first = assoc.next_pose
        stop = min(len(assoc.flange), self.first + size + BOOTSTRAP_SKIPS)
        self.flange = assoc.flange[:stop]
        nominal = self.flange[:, :3, :3] @ assoc.tool_guess_mm + self.flange[:, :3, 3]
        self.pose_apart = np.linalg.norm(nominal[:, None] - nominal[None], axis=2)
        self.stop_apart = np.linalg.norm(self.points[:, None] - self.points[None], axis=2)
        # A tool t from the guess moves the distance of poses i, j by at most
        # |(R_i - R_j) t| <= 2 sin(angle_ij / 2) |t|.
        rot = self.flange[:, :3, :3]
        cos = (np.einsum("iab,jab->ij", rot, rot) - 1.0) / 2.0
        chord = 2.0 * np.sin(np.arccos(np.clip(cos, -1.0, 1.0)) / 2.0)
        self.slack = assoc.bound_mm + chord * assoc.tool_bound_mm
        self.best_cost = BOOTSTRAP_SKIPS + BOOTSTRAP_REJECTS
        self.found: tuple[tuple[int, float], list, Registration] | None = None

    def best(self) -> tuple[list[tuple[int, int]], Registration] | None:
        """``([(stop index, pose), ...], registration)`` of the winning set, or None."""
        self._extend([])
        return None if self.found is None else (self.found[1], self.found[2])

    def _tolerance_of(self, loo_mm: np.ndarray, k: int) -> float:
        """The rule's tolerance from the leave-one-out misfits of all stops but ``k``, mm."""
        others = np.delete(loo_mm, k)
        if len(others) < RULE_STOPS:
            return self.assoc.bound_mm
        scaled = TOLERANCE_FACTOR * float(np.sqrt(np.mean(others**2)))
        return min(max(scaled, TOLERANCE_FLOOR_MM), self.assoc.bound_mm)

    def _cost(self, chosen) -> int:
        stop, pose = chosen[-1]
        return (stop + 1 - len(chosen)) + (pose - self.first + 1 - len(chosen))

    def _extend(self, chosen: list[tuple[int, int]]) -> None:
        if len(chosen) == self.size:
            self._judge(chosen)
            return
        need = self.size - len(chosen)
        after_stop = chosen[-1][0] + 1 if chosen else 0
        after_pose = chosen[-1][1] + 1 if chosen else self.first
        for a in range(after_stop, len(self.points) - need + 1):
            for i in range(after_pose, len(self.flange) - need + 1):
                trial = [*chosen, (a, i)]
                if self._cost(trial) > self.best_cost:
                    break
                if not self._distances_fit(chosen, a, i):
                    continue
                if len(trial) in PRUNE_DEPTHS and len(trial) < self.size and not self._fits(trial):
                    continue
                self._extend(trial)

    def _distances_fit(self, chosen, a: int, i: int) -> bool:
        if not chosen:
            return True
        stops = [b for b, _ in chosen]
        poses = [j for _, j in chosen]
        error = np.abs(self.stop_apart[a, stops] - self.pose_apart[i, poses])
        return bool(np.all(error <= self.slack[i, poses]))

    def _fits(self, chosen) -> bool:
        """A partial set: registered within the bound (a cheap cut before the full check)."""
        reg = self._register(chosen, leave_one_out=False)
        return reg is not None and bool(np.max(reg.misfit_mm) <= self.assoc.bound_mm)

    def _register(
        self, chosen, without: int | None = None, leave_one_out: bool = True
    ) -> Registration | None:
        kept = [c for n, c in enumerate(chosen) if n != without]
        return register(
            self.flange[[i for _, i in kept]],
            self.points[[a for a, _ in kept]],
            self.assoc.tool_guess_mm,
            self.assoc.tool_bound_mm,
            leave_one_out=leave_one_out,
        )

    def _judge(self, chosen) -> None:
        """Keep ``chosen`` if every stop passes the rule against the others and it is cheapest.

        The whole set's fit gives every stop's leave-one-out misfit at once; the
        tolerance of the others, though, must not feel the stop judged (a wrong
        stop inflates the others' misfits). So the stops nearest to failing
        (:data:`JUDGED_EXACTLY`) are judged against a registration refitted
        without them, the rest against the whole set's others.
        """
        whole = self._register(chosen)
        if whole is None or np.max(whole.misfit_mm) > self.assoc.bound_mm:
            return
        n = len(chosen)
        loose = np.array([self._tolerance_of(whole.loo_mm, k) for k in range(n)])
        if np.any(whole.loo_mm > loose):
            return
        for k in np.argsort(loose - whole.loo_mm)[:JUDGED_EXACTLY]:
            a, i = chosen[k]
            others = self._register(chosen, without=int(k))
            if others is None:
                return
            miss = np.linalg.norm(others.predict(self.flange[i : i + 1])[0] - self.points[a])
            if miss > self.assoc.tolerance(others):
                return
        key = (self._cost(chosen), whole.rms_mm)
        if self.found is None or key < self.found[0]:
            self.found = (key, list(chosen), whole)
            self.best_cost = key[0]
