"""The order a plan visits its poses: short in time, every move safe, vias where needed.

Moves are joint-space lines at the model's speed and acceleration ceilings;
a move the cell's collision checks refuse is avoided by another order, else
by vias through the arm held upright; a move neither makes safe is returned
as unjoined, and the planner replaces one of its poses.

Joint angles rad; everything in the robot base frame.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from calibrator import cell as cells
from calibrator.planning.plan import Plan

if TYPE_CHECKING:
    from calibrator import robots


@dataclass(frozen=True)
class Ordered:
    """The poses in a short-time order, and the moves of it no safe way joins.

    Attributes
    ----------
    plan : Plan
        The poses in visiting order, with vias where a direct move is unsafe
        (none before a pose no safe way reaches).
    order : ndarray, shape (N,)
        Row of the given poses at each place of ``plan``.
    unjoined : tuple of (int, int, str)
        Moves between rows of the given poses (from, to, the first reason)
        that are unsafe directly and through the arm held upright; the move
        from the last pose back to the first (a program's way home) among them.
    """

    plan: Plan
    order: np.ndarray
    unjoined: tuple[tuple[int, int, str], ...]


class MoveVerdicts:
    """Motion checks already made, by the two poses' joint values (kept between orderings).

    The planner orders the poses again after replacing one that no safe
    move joins; the moves between the poses it keeps are not checked twice.
    """

    def __init__(self, chk: cells.Checker, box: np.ndarray) -> None:
        self.chk, self.box = chk, box
        self._direct: dict[tuple[bytes, bytes], np.ndarray] = {}
        self._vias: dict[tuple[bytes, bytes], np.ndarray | None] = {}

    def direct(self, qa: np.ndarray, qb: np.ndarray) -> np.ndarray:
        """Faults (M, 4) of the moves ``qa[i] -> qb[i]`` (M, 6), checking only new ones."""
        keys = [(a.tobytes(), b.tobytes()) for a, b in zip(qa, qb, strict=True)]
        new = [i for i, k in enumerate(keys) if k not in self._direct]
        if new:
            faults = cells.motion_faults(self.chk, qa[new], qb[new])
            for i, f in zip(new, faults, strict=True):
                # The joint-space line is the same both ways.
                self._direct[keys[i]] = self._direct[keys[i][::-1]] = f
        return np.array([self._direct[k] for k in keys]).reshape(len(keys), 4)

    def joinable(self, qa: np.ndarray, qb: np.ndarray) -> np.ndarray:
        """Whether a safe move joins ``qa`` (6,) to each of ``qb`` (M, 6), shape (M,) bool.

        Directly, or through the arm held upright: every way up of
        :func:`_rise_paths` ends with the arm upright and the wrist neutral,
        so for poses that can rise (:func:`can_rise`) the vias are safe when
        the turn between their two neutral poses is (the ordering checks
        the vias it makes in full).
        """
        qb = np.atleast_2d(qb)
        ok = np.logical_not(self.direct(np.tile(qa, (len(qb), 1)), qb).any(axis=1))
        todo = np.flatnonzero(~ok)
        if todo.size:
            ends = np.vstack([qa, qb[todo]])
            neutral = _rise_paths(self.chk, ends, self.box)[0][:, -1]
            inside = np.all((neutral >= self.box[:, 0]) & (neutral <= self.box[:, 1]), axis=1)
            inside &= ~cells.checks.collision_faults(self.chk, neutral).any(axis=1)
            turn = self.direct(np.tile(neutral[0], (todo.size, 1)), neutral[1:])
            ok[todo] = ~turn.any(axis=1) & inside[1:] & inside[0]
        return ok

    def vias(self, qa: np.ndarray, qb: np.ndarray) -> np.ndarray | None:
        """Vias (k, 6) from ``qa`` to ``qb`` through the arm held upright, or None."""
        key = (qa.tobytes(), qb.tobytes())
        if key not in self._vias:
            self._vias[key] = _upright_vias(self.chk, qa, qb, self.box)
        return self._vias[key]


def order_joined(
    chk: cells.Checker,
    q: np.ndarray,
    box: np.ndarray,
    speed: float,
    accel: float,
    verdicts: MoveVerdicts | None = None,
) -> Ordered:
    """The poses in a short-time order, vias where a direct move is unsafe, and what stays unjoined.

    The order is made at the given speed (rad/s) and acceleration (rad/s^2);
    an unsafe move is forbidden and the order made again (up to 8 times),
    then turned so that the way back from the last pose to the first is
    safe; a move still unsafe gets vias through the arm held upright
    (:func:`_upright_vias`, every via within ``box`` (6, 2), rad). The moves
    neither makes safe are returned, not raised: the planner replaces one of
    their poses.

    Parameters
    ----------
    chk : calibrator.cell.Checker
    q : ndarray, shape (N, 6)
        The poses, rad.
    box : ndarray, shape (6, 2)
        Joint ranges the vias keep within, rad.
    speed, accel : float
    verdicts : MoveVerdicts, optional
        Checks made before (by joint values), reused and added to.
    """
    verdicts = MoveVerdicts(chk, box) if verdicts is None else verdicts
    times = cells.time_matrix(q, speed, accel)
    verdict: dict[tuple[int, int], np.ndarray] = {}
    order = cells.order_poses(times)
    for attempt in range(8):
        edges = list(zip(order[:-1].tolist(), order[1:].tolist(), strict=True))
        new = [e for e in edges if e not in verdict]
        if new:
            a, b = np.array(new).T
            for e, f in zip(new, verdicts.direct(q[a], q[b]), strict=True):
                verdict[e] = verdict[e[::-1]] = f
        bad = [e for e in edges if verdict[e].any()]
        if not bad or attempt == 7:
            break  # every edge of this order has a verdict: vias below for the bad ones
        for a, b in bad:
            times[a, b] = times[b, a] = np.inf
        order = cells.order_poses(times)
    order = _close_safely(verdicts, q, order, times, verdict)
    vias, unjoined = [], []
    for k, i in enumerate(order):
        if k == 0 or not verdict[(int(order[k - 1]), int(i))].any():
            vias.append(np.zeros((0, 6)))
            continue
        a, b = int(order[k - 1]), int(i)
        via = verdicts.vias(q[a], q[b])
        if via is None:
            unjoined.append((a, b, cells.MOTION_REASONS[int(np.argmax(verdict[(a, b)]))]))
            via = np.zeros((0, 6))
        vias.append(via)
    if len(order) > 1:
        # A program returns home (the first pose) from the last along the line, without vias.
        last, first = int(order[-1]), int(order[0])
        if verdict[(last, first)].any():
            reason = cells.MOTION_REASONS[int(np.argmax(verdict[(last, first)]))]
            unjoined.append((last, first, reason))
    return Ordered(Plan(q[order], tuple(vias)), np.asarray(order), tuple(unjoined))


def _close_safely(
    verdicts: MoveVerdicts, q: np.ndarray, order: np.ndarray, times: np.ndarray, verdict: dict
) -> np.ndarray:
    """``order`` turned so that the move from its last pose back to its first is safe.

    A program returns from the last pose to its home, by default the first
    pose, along the joint-space line: that closing move must pass the same
    checks as every other. If it does not, the cycle starts after its longest
    safe direct move instead (the old closing move becomes an inner one, given
    vias like any other). ``verdict`` maps ``(a, b)`` to the move's faults and
    gains the closing move's.
    """
    if len(order) < 2:
        return order
    first, last = int(order[0]), int(order[-1])
    if (last, first) not in verdict:
        faults = verdicts.direct(q[last][None], q[first][None])[0]
        verdict[(last, first)] = verdict[(first, last)] = faults
    if not verdict[(last, first)].any():
        return order
    pairs = list(zip(order[:-1].tolist(), order[1:].tolist(), strict=True))
    safe = [k for k, e in enumerate(pairs) if not verdict[e].any()]
    if not safe:
        return order  # every move needs vias: the closing one is refused where it is used
    k = max(safe, key=lambda j: times[pairs[j]] if np.isfinite(times[pairs[j]]) else 0.0)
    return np.roll(order, -(k + 1))


def _rise_paths(chk, q: np.ndarray, box: np.ndarray | None = None) -> list[np.ndarray]:
    """Ways up from each pose of ``q`` (N, 6): via lists (N, k, 6).

    Each ends with the arm upright and the wrist neutral (joints 1 and 6 as
    in ``q``), where turning joints 1 and 6 to another pose's is safe: shoulder
    and elbow together, elbow first, or shoulder first, then the wrist.
    Upright and neutral are taken within ``box`` (6, 2), rad, when given: an
    arm whose elbow cannot stand straight up holds it at its limit (the IRB
    2400's joint 3 at -60 deg), outside the margin the vias keep, and
    without this no via of it was ever used.
    """
    up2, up3 = chk.geometry.upright_rad
    wrist4, wrist5 = chk.geometry.neutral_wrist_rad
    if box is not None:
        up2, up3 = np.clip((up2, up3), box[1:3, 0], box[1:3, 1])
        wrist4, wrist5 = np.clip((wrist4, wrist5), box[3:5, 0], box[3:5, 1])
    upright = q.copy()
    upright[:, 1:3] = (up2, up3)
    neutral = upright.copy()
    neutral[:, 3:5] = (wrist4, wrist5)
    elbow, shoulder = q.copy(), q.copy()
    elbow[:, 2] = up3
    shoulder[:, 1] = up2
    return [
        np.stack([upright, neutral], 1),
        np.stack([elbow, upright, neutral], 1),
        np.stack([shoulder, upright, neutral], 1),
    ]


def can_rise(chk: cells.Checker, q: np.ndarray, box: np.ndarray | None = None) -> np.ndarray:
    """Which poses of ``q`` (N, 6) have a safe way up (:func:`_rise_paths`), shape (N,) bool."""
    ok = np.zeros(len(q), dtype=bool)
    for vias in _rise_paths(chk, q, box):
        todo = np.flatnonzero(~ok)
        if not todo.size:
            break
        path = np.concatenate([q[todo, None], vias[todo]], axis=1)  # (M, k + 1, 6)
        k = path.shape[1] - 1
        safe = ~cells.checks.collision_faults(chk, vias[todo].reshape(-1, 6)).any(axis=1)
        moves = cells.motion_faults(chk, path[:, :-1].reshape(-1, 6), path[:, 1:].reshape(-1, 6))
        safe &= ~moves.any(axis=1)
        ok[todo] = safe.reshape(-1, k).all(axis=1)
    return ok


def _upright_vias(chk, qa: np.ndarray, qb: np.ndarray, box: np.ndarray) -> np.ndarray | None:
    """Vias from ``qa`` to ``qb`` through the arm held upright, or None if none is safe.

    Each way up of :func:`_rise_paths` from ``qa``, then across with the arm
    upright, then down to ``qb`` by one of its ways up reversed. Each via pose
    and each move between them must pass the collision checks.
    """
    # Up from qa, across upright, down to qb (the way up reversed): each way up
    # of qa with each of qb, shortest first.
    ups_a = [v[0] for v in _rise_paths(chk, qa[None], box)]
    ups_b = [v[0][::-1] for v in _rise_paths(chk, qb[None], box)]
    tries = sorted(([*a, *b] for a in ups_a for b in ups_b), key=len)
    for vias in tries:
        via = np.array(vias)
        if np.any((via < box[:, 0]) | (via > box[:, 1])):
            continue
        if cells.checks.collision_faults(chk, via).any():
            continue
        path = np.vstack([qa, via, qb])
        if not cells.motion_faults(chk, path[:-1], path[1:]).any():
            return via
    return None


def estimate(
    plan: Plan,
    model: robots.RobotDescription,
    speed_rad_s: float,
    accel_rad_s2: float,
    **kwargs: Any,
) -> cells.CellTime:
    """:func:`calibrator.cell.cell_time` of a :class:`Plan` (all its rows, vias included).

    ``speed_rad_s`` (rad/s) and ``accel_rad_s2`` (rad/s^2) are lowered to the
    model's caps; ``kwargs`` go to :func:`calibrator.cell.cell_time`
    (``settle_s``, ``readings``, ``rate_hz``).
    """
    speed = min(speed_rad_s, model.move_speed_cap_rad_s)
    accel = min(accel_rad_s2, model.move_accel_cap_rad_s2)
    return cells.cell_time(plan.path_rad, len(plan.q_rad), speed, accel, **kwargs)
