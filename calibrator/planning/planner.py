"""The cell-aware planner: ``n`` poses every cell check allows, observable, in time order.

Candidates (sampled, or the user's) are kept inside the joint limits less a
margin, checked in the cell (:mod:`calibrator.cell`), chosen D-optimally
(:mod:`calibrator.planning.design`) and ordered with safe moves
(:mod:`calibrator.planning.ordering`).

Joint angles rad, lengths mm, positions in the robot base frame.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from calibrator import cell as cells
from calibrator.cell.timing import CellTime
from calibrator.planning.design import (
    Observability,
    leave_one_out,
    observability,
    select_d_optimal,
)
from calibrator.planning.ordering import MoveVerdicts, can_rise, order_joined
from calibrator.planning.plan import Plan, PlanError, PlanOrigin, point
from calibrator.planning.sampling import distinct, joint_box, sample

if TYPE_CHECKING:
    from calibrator import robots

SELECTIONS = ("d-optimal", "random", "first")


@dataclass(frozen=True)
class PlanReport:
    """A checked, ordered plan and how it was made.

    Attributes
    ----------
    plan : Plan
        Measured poses in time-optimal order, with vias where a direct move is unsafe.
    candidates : int
        Candidates considered.
    dropped : dict of str to int
        Candidates dropped per reason, in the order the checks ran (a
        candidate counts under the first reason it fails).
    names : tuple of str
        Parameters the plan's Jacobian blocks refer to (the candidates' free set).
    blocks : ndarray, shape (N, 3, P)
        Scaled identification Jacobian of the plan's poses on ``names``.
    selection_time, ordered_time : calibrator.cell.CellTime
        Estimated run time in the selection order and in the plan's order.
    unjoined : int
        Chosen poses replaced because no safe move joined them to the others
        (directly, in any order tried, or through the arm held upright); also
        counted in ``dropped`` as ``no safe move``.
    """

    plan: Plan
    candidates: int
    dropped: dict
    names: tuple
    blocks: np.ndarray
    selection_time: CellTime
    ordered_time: CellTime
    unjoined: int = 0


def make_checked(
    model: robots.RobotDescription,
    n: int,
    cell: cells.Cell,
    tool_mm: ArrayLike,
    *,
    margin_rad: float = np.radians(5.0),
    candidates: ArrayLike | None = None,
    n_candidates: int | None = None,
    method: str = "halton",
    selection: str = "d-optimal",
    seed: int = 0,
    settle_s: float = 0.5,
    readings: int = 10,
    rate_hz: float = 10.0,
    names: tuple | None = None,
    speed_rad_s: float | None = None,
    accel_rad_s2: float | None = None,
) -> PlanReport:
    """A plan of ``n`` poses every check of :mod:`calibrator.cell` allows, in time-optimal order.

    Candidates (sampled, or the user's) are kept inside the joint limits less
    ``margin_rad``, made distinct, then checked (aim, collisions, line of
    sight; see :data:`calibrator.cell.REASONS`). ``n`` are selected
    (D-optimal by default) and must determine the candidates' free
    parameters; they are then ordered to minimise the move time at the
    model's speed and acceleration caps, and every move between consecutive
    poses is checked along its joint-space line: an unsafe move is avoided by
    another order, else by vias with the arm upright, else one of its poses is
    replaced by the next best candidate (:func:`_choose_joined`).

    Parameters
    ----------
    model : calibrator.robots.RobotDescription
    n : int
    cell : calibrator.cell.Cell
    tool_mm : array_like, shape (3,)
        Reflector position on the flange, mm.
    margin_rad : float
        Distance kept from the joint limits, rad.
    candidates : array_like, shape (C, 6), optional
        The user's joint vectors (rad) instead of sampled ones.
    n_candidates : int, optional
        Sampled candidates [default: ``max(300 n, 6000)``, four times more
        while fewer than ``4 n`` pass, up to :data:`MAX_SAMPLED`; about one
        in fifty passes every check from a typical tracker position].
    method : {'halton', 'random'}
        Sampling of the candidates (:func:`calibrator.planning.sampling.sample`).
    selection : {'d-optimal', 'random', 'first'}
        How ``n`` are chosen among the candidates that pass.
    seed : int
        Seed of the sampling and of a random selection.
    settle_s, readings, rate_hz
        For the time estimate (:func:`calibrator.cell.cell_time`).
    names : tuple of str, optional
        Parameters the D-optimal choice serves (see :func:`observability`);
        default every one the model can identify.
    speed_rad_s, accel_rad_s2 : float, optional
        Leading-joint speed (rad/s) and acceleration (rad/s^2) of the time
        estimate: those the run will move at. Default the model's ceilings,
        at which the order is made either way.

    Raises
    ------
    PlanError
        Too few candidates pass (with the counts per reason), fewer than
        ``n`` can be joined by safe moves ("found k of n poses", with the
        counts), or the chosen poses cannot determine the parameters.
    calibrator.cell.CellError
        The tracker is placed where the arm could reach it.
    """
    if selection not in SELECTIONS:
        raise PlanError(f"unknown selection {selection!r}; use one of {', '.join(SELECTIONS)}")
    chk = cells.checker(cells.arm_geometry(model.name, model.mdh, tool_mm), cell)
    cells.check_tracker_placement(chk)
    box = joint_box(model.joint_limits_rad, margin_rad)
    if candidates is not None or n_candidates is not None:
        if candidates is not None:
            pool = np.asarray(candidates, dtype=float)
        else:
            assert n_candidates is not None  # the branch's condition
            pool = sample(box, n_candidates, method, seed)

        pool, dropped = _passing(chk, pool, box)
    else:
        # Sample more until there is a choice (four candidates per pose), up to a bound.
        count = min(max(300 * n, 6000), MAX_SAMPLED)
        while True:
            pool, dropped = _passing(chk, sample(box, count, method, seed), box)
            if len(pool) >= 4 * n or count >= MAX_SAMPLED:
                break
            count = min(4 * count, MAX_SAMPLED)
    if model.controller_limits_rad is not None:
        # A coupled joint's limits are the controller's (FANUC's J3): the model's box
        # the candidates come from holds more than they allow.
        inside = ~model.outside_limits(pool, -margin_rad).any(axis=1)
        reason = "outside joint limits less margin"
        dropped[reason] = dropped.get(reason, 0) + int((~inside).sum())
        pool = pool[inside]
    total = len(pool) + sum(dropped.values())
    if len(pool) < n:
        counts = ", ".join(f"{reason} {k}" for reason, k in dropped.items() if k)
        raise PlanError(
            f"only {len(pool)} of {total} candidates pass the cell's checks ({counts}); "
            f"{n} asked (more candidates, another tracker position or a smaller margin?)"
        )
    # The free set is the model's (from a rich reference set of poses), not what these
    # candidates happen to see: too few or too alike candidates must fail the rank test.
    reference = np.random.default_rng(0).uniform(box[:, 0], box[:, 1], (64, 6))
    full = observability(model.mdh, np.vstack([reference, pool]), _tool(tool_mm), names=names)
    obs = Observability(full.names, full.blocks[len(reference) :])
    speed, accel = model.move_speed_cap_rad_s, model.move_accel_cap_rad_s2
    chosen_at, plan, unjoined = _choose_joined(
        chk, pool, obs, n, box, selection, seed, speed, accel, total, dropped
    )
    blocks = obs.blocks[chosen_at]
    _check_rank(blocks, obs.names, n, len(pool))
    chosen = pool[chosen_at]
    # What the plan's checks held for, recorded in its file (read_plan, made_for).
    at = cell.tracker_at_mm
    plan = Plan(
        plan.q_rad,
        plan.via_rad,
        PlanOrigin(
            model.name,
            point(tool_mm),
            None if at is None else point(at),
            model.digest,
            guessed_geometry(model),
        ),
    )
    # The estimate at the speeds the run will move at (the order is made at the ceilings).
    speed = speed if speed_rad_s is None else speed_rad_s
    accel = accel if accel_rad_s2 is None else accel_rad_s2
    index = [int(np.flatnonzero(np.all(chosen == q, axis=1))[0]) for q in plan.q_rad]
    return PlanReport(
        plan=plan,
        candidates=total,
        dropped=dropped,
        names=obs.names,
        blocks=blocks[index],
        selection_time=cells.cell_time(
            chosen, n, speed, accel, settle_s=settle_s, readings=readings, rate_hz=rate_hz
        ),
        ordered_time=cells.cell_time(
            plan.path_rad, n, speed, accel, settle_s=settle_s, readings=readings, rate_hz=rate_hz
        ),
        unjoined=unjoined,
    )


#: Most candidates :func:`make_checked` samples on its own.
MAX_SAMPLED = 400_000
#: Most orderings of a choice :func:`make_checked` makes: each that leaves a move
#: unsafe drops at least one candidate, so the choice ends anyway; this bounds the
#: time spent on a cell that leaves few joinable poses (an ordering takes about a second).
MAX_ROUNDS = 40


def _choose_joined(
    chk: cells.Checker,
    pool: np.ndarray,
    obs: Observability,
    n: int,
    box: np.ndarray,
    selection: str,
    seed: int,
    speed: float,
    accel: float,
    total: int,
    dropped: dict,
) -> tuple[np.ndarray, Plan, int]:
    """``n`` candidates any two of which a safe move joins, chosen and ordered.

    Any two poses must be joinable: directly, or through the arm held upright.
    A chosen pose the arm cannot leave upwards safely (the shoulder past
    horizontal on the far side, where the way up turns through the floor) is
    dropped and the choice made again; so is one pose of each move the order
    leaves unsafe (directly, in any order tried, and through the arm upright),
    with the poses no safe move joins to the other one (:func:`_to_replace`).
    The choice among the candidates left is then made again, so the plan
    stays the selection's best of what can be joined. Checked on the chosen
    poses only (a motion check per candidate is slow). Each round drops at
    least one candidate, so the choice ends; at most :data:`MAX_ROUNDS`
    orderings are made.

    Parameters
    ----------
    chk : calibrator.cell.Checker
    pool : ndarray, shape (C, 6)
        Candidates that pass every pose check, rad.
    obs : Observability
        Their Jacobian blocks.
    n : int
    box : ndarray, shape (6, 2)
        Joint ranges (limits less the margin), rad.
    selection, seed
        As :func:`make_checked`'s.
    speed, accel : float
        Of the ordering, rad/s and rad/s^2.
    total : int
        Candidates considered (for the message).
    dropped : dict
        Counts per reason; gains ``no safe way up`` and ``no safe move``.

    Returns
    -------
    chosen : ndarray, shape (n,)
        Rows of ``pool``, in the selection's order.
    plan : Plan
    unjoined : int
        Chosen poses replaced because no safe move joined them to the others.

    Raises
    ------
    PlanError
        Fewer than ``n`` candidates left that can be joined ("found k of n"),
        or no joined choice within :data:`MAX_ROUNDS` orderings ("found k of
        n", k joined in the last).
    """
    usable = np.ones(len(pool), dtype=bool)
    risen = np.zeros(len(pool), dtype=bool)  # a safe way up found
    shuffled = np.random.default_rng(seed).permutation(len(pool))
    verdicts = MoveVerdicts(chk, box)
    no_way_up = unjoined = joined = rounds = 0
    reasons: dict[str, int] = {}
    while rounds < MAX_ROUNDS:
        left = np.flatnonzero(usable)
        if len(left) < n:
            raise PlanError(
                f"found {len(left)} of {n} poses: of {total} candidates {len(pool)} pass the "
                f"cell's checks, {no_way_up} of them have no safe way up"
                + _unjoined_text(unjoined, reasons)
                + "; more candidates, another tracker position or fewer poses?"
            )
        if selection == "first":
            picks = left[:n]
        elif selection == "random":
            picks = shuffled[usable[shuffled]][:n]
        else:
            picks = left[select_d_optimal(obs.blocks[left], n)]
        todo = picks[~risen[picks]]
        if todo.size:
            up = can_rise(chk, pool[todo], box)
            risen[todo[up]] = True
            if not up.all():
                usable[todo[~up]] = False
                no_way_up += int((~up).sum())
                continue
        # Poses without a way up go a round each too, but cost no ordering: not counted.
        rounds += 1
        ordered = order_joined(chk, pool[picks], box, speed, accel, verdicts)
        if not ordered.unjoined:
            dropped["no safe way up"] = no_way_up
            dropped["no safe move"] = unjoined
            return picks, ordered.plan, unjoined
        out = _to_replace(pool[picks], obs.blocks[picks], ordered.unjoined, verdicts)
        for _a, _b, reason in ordered.unjoined:
            reasons[reason] = reasons.get(reason, 0) + 1
        usable[picks[out]] = False
        unjoined += len(out)
        joined = n - len(out)
    raise PlanError(
        f"found {joined} of {n} poses joined by safe moves after {MAX_ROUNDS} choices"
        + _unjoined_text(unjoined, reasons)
        + "; more candidates, another tracker position or fewer poses?"
    )


def _unjoined_text(unjoined: int, reasons: dict) -> str:
    """``, no safe move joined k to the others (reason count, ...)`` or nothing."""
    if not unjoined:
        return ""
    why = ", ".join(f"{reason} {k}" for reason, k in reasons.items())
    return f", no safe move joined {unjoined} to the other poses ({why})"


def _to_replace(
    q: np.ndarray, blocks: np.ndarray, unjoined: tuple, verdicts: MoveVerdicts
) -> np.ndarray:
    """Which chosen poses to give up for the unjoined moves, shape (k,), sorted rows of ``q``.

    ``q`` (n, 6) and ``blocks`` (n, 3, P) of the chosen poses; ``unjoined``
    moves ``(a, b, reason)`` between rows of them. Of each move whose poses
    are both still kept, the pose a safe move joins to more of the others is
    kept (on a tie, the one whose loss costs ``log det(J^T J)`` more); the
    other is given up, and so is every pose no safe move joins to the kept
    one: an obstacle that blocks the turn of the arm held upright splits the
    poses in two, and the smaller side goes at once, not a pose a round.
    """
    n = len(q)
    loss = leave_one_out(blocks)
    out: set[int] = set()
    for a, b, _reason in unjoined:
        if a in out or b in out:
            continue
        kept = [i for i in range(n) if i not in out]
        joins = {i: verdicts.joinable(q[i], q[kept]) for i in (a, b)}
        keep = max((a, b), key=lambda i: (int(joins[i].sum()), loss[i]))
        out.add(b if keep == a else a)
        out.update(i for i, ok in zip(kept, joins[keep], strict=True) if not ok and i != keep)
    return np.array(sorted(out), dtype=int)


def guessed_geometry(model: robots.RobotDescription) -> str | None:
    """What of the arm's collision body is guessed, not fitted to its geometry; None: nothing.

    A URDF whose collision meshes are missing (or that has no collision
    geometry) gets capsules drawn along its links between the joints
    (:func:`calibrator.robots.urdf.fit_body`): every pose and move is then
    checked against that guess, which ``plan`` and ``measure`` say.
    """
    body = model.body
    return body.guessed or None if body is not None else None


def _passing(chk, pool: np.ndarray, box: np.ndarray) -> tuple[np.ndarray, dict]:
    """The candidates of ``pool`` (C, 6) that pass every check, and the count dropped per reason.

    Duplicates first, then in chunks (bounded memory on large candidate sets).
    """
    pool = np.asarray(pool, dtype=float).reshape(-1, 6)
    first = np.zeros(len(pool), dtype=bool)
    first[distinct(pool)] = True
    kept, dropped = [], {"duplicate": int((~first).sum())}
    pool = pool[first]
    for lo in range(0, max(len(pool), 1), 20000):
        part, counts = _passing_chunk(chk, pool[lo : lo + 20000], box)
        kept.append(part)
        for reason, k in counts.items():
            dropped[reason] = dropped.get(reason, 0) + k
    return np.concatenate(kept), dropped


def _passing_chunk(chk, pool: np.ndarray, box: np.ndarray) -> tuple[np.ndarray, dict]:
    dropped: dict[str, int] = {}

    def keep(mask, reason):
        nonlocal pool
        dropped[reason] = int((~mask).sum())
        pool = pool[mask]

    keep(
        np.all((pool >= box[:, 0]) & (pool <= box[:, 1]), axis=1),
        "outside joint limits less margin",
    )
    # Cheap checks first: the aim drops most candidates before the capsules are placed.
    near = cells.checks.singularity_faults(chk, pool)
    for r, reason in enumerate(cells.checks.SINGULARITY_REASONS):
        keep(~near[:, r], reason)
        near = near[~near[:, r]]
    keep(~cells.checks.aim_faults(chk, pool)[:, 1], "acceptance angle")
    keep(~cells.checks.aim_faults(chk, pool)[:, 0], "tracker range")
    hits = cells.checks.collision_faults(chk, pool)
    for r, reason in enumerate(cells.MOTION_REASONS):
        keep(~hits[:, r], reason)
        hits = hits[~hits[:, r]]
    keep(~cells.checks.sight_faults(chk, pool), "line of sight")
    return pool, dropped


def _tool(tool_mm) -> np.ndarray:
    flange2tool = np.eye(4)
    flange2tool[:3, 3] = np.asarray(tool_mm, dtype=float)
    return flange2tool


def _check_rank(blocks: np.ndarray, names: tuple, n: int, pool: int) -> None:
    """Refuse poses that cannot determine every parameter of ``names`` (a rank test)."""
    jac = blocks.reshape(-1, blocks.shape[-1])
    sv = np.linalg.svd(jac, compute_uv=False)
    rank = int((sv > 1e-9 * sv.max()).sum()) if sv.size and sv.max() > 0 else 0
    if rank < len(names):
        raise PlanError(
            f"the {n} poses chosen from {pool} distinct candidates determine only {rank} of the "
            f"{len(names)} parameters ({', '.join(names)}): more poses, or more varied candidates"
        )
