"""Pose plans: joint configurations to measure, checked whole before any motion.

A plan is an array of joint targets, shape (N, 6), rad. It is made from a
candidate set (scrambled Halton points, seeded random points,
or the user's own CSV of joint angles), filtered by what a real cell needs,
and reduced to the N most informative poses:

- inside the model's joint limits less a user margin (and within +-pi, so no
  cable wraps);
- the reflector (or 6-DoF probe) faces the tracker: the angle between the
  tool's z axis and the line from the tool point to the tracker is within
  the acceptance angle (+-30 deg by default; a Leica 1.5" red-ring reflector
  accepts about +-30 deg);
- the tool point and the wrist (origins of frames 4 to 6) stay above a floor
  height in the base frame;
- selection by **D-optimality**: greedily add the candidate that most
  increases ``log det(J^T J)`` of the identification Jacobian, i.e. the
  observability index O1 of Borm and Menq (1991), the product of the singular
  values; Sun and Hollerbach (2008, "Observability index selection for robot
  calibration", ICRA) compare it with the other indices and show greedy
  selection of this kind. Angle columns of the Jacobian are divided by
  :data:`ANGLE_SCALE_MM` so millimetres and radians weigh alike (otherwise the
  criterion depends on the units chosen).

Frames: joint angles rad, lengths mm, positions in the robot base frame.
"""

from __future__ import annotations

import csv
import hashlib
import io
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from calibrator import kinematics, measurement, parameters, strict
from calibrator.errors import CalibrationError
from calibrator.identify.halton import halton

#: Scale of angle columns (mm per rad) before computing the criterion: about an arm's reach.
ANGLE_SCALE_MM = 1000.0
JOINT_COLUMNS = tuple(f"q{i}_rad" for i in range(1, 7))
DEG_COLUMNS = tuple(f"q{i}_deg" for i in range(1, 7))
SELECTIONS = ("d-optimal", "random", "first")


class PlanError(CalibrationError):
    """A plan is invalid (limits, count, file) or cannot be made with these constraints."""


@dataclass(frozen=True)
class CellConstraints:
    """What the cell allows.

    Attributes
    ----------
    margin_rad : float
        Keep every joint this far inside its limits, rad.
    tracker_at_mm : ndarray, shape (3,), or None
        Rough tracker position in the base frame, mm; None skips the
        acceptance-angle check.
    acceptance_rad : float
        Half-angle of the reflector's acceptance cone, rad.
    floor_mm : float or None
        Lowest allowed z of the tool point and the wrist, base frame, mm.
    flange2tool : ndarray, shape (4, 4)
        Tool (reflector) frame on the flange, mm; its z axis is the reflector's axis.
    """

    margin_rad: float = np.radians(5.0)
    tracker_at_mm: np.ndarray | None = None
    acceptance_rad: float = np.radians(30.0)
    floor_mm: float | None = 0.0
    flange2tool: np.ndarray = field(default_factory=lambda: np.eye(4))


def joint_box(joint_limits_rad, margin_rad) -> np.ndarray:
    """Sampling box, shape (6, 2), rad: the limits within +-pi, less ``margin_rad``."""
    limits = np.asarray(joint_limits_rad, dtype=float)
    box = np.column_stack(
        [
            np.maximum(limits[:, 0], -np.pi) + margin_rad,
            np.minimum(limits[:, 1], np.pi) - margin_rad,
        ]
    )
    if np.any(box[:, 0] >= box[:, 1]):
        raise PlanError(f"a joint margin of {np.degrees(margin_rad):.3g} deg leaves no joint range")
    return box


def sample(box, n, method="halton", seed=0) -> np.ndarray:
    """``n`` joint vectors in ``box`` (6, 2): scrambled Halton or uniform random, seeded. Rad."""
    rng = np.random.default_rng(seed)
    if method == "halton":
        # The project's scrambled Halton (scipy.stats.qmc.Halton's construction) keeps
        # scipy.stats' half-second import out of measure's start-up.
        unit = halton(n, 6, rng)
    elif method == "random":
        unit = rng.random((n, 6))
    else:
        raise PlanError(f"unknown sampling method {method!r}; use halton or random")
    return box[:, 0] + unit * (box[:, 1] - box[:, 0])


def feasible(mdh, q, cell: CellConstraints) -> np.ndarray:
    """Which joint vectors the cell allows (acceptance angle, floor), shape (N,) bool.

    Parameters
    ----------
    mdh : array_like, shape (6, 5)
        Nominal MDH table (mm, rad).
    q : array_like, shape (N, 6)
        Joint angles, rad.
    cell : CellConstraints
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    base2flange, link = kinematics.chain(mdh, q, all_frames=True)
    base2tool = base2flange @ np.asarray(cell.flange2tool, dtype=float)
    ok = np.ones(len(q), dtype=bool)
    if cell.tracker_at_mm is not None:
        to_tracker = np.asarray(cell.tracker_at_mm, dtype=float) - base2tool[:, :3, 3]
        to_tracker /= np.maximum(np.linalg.norm(to_tracker, axis=1, keepdims=True), 1e-9)
        ok &= np.einsum("nj,nj->n", base2tool[:, :3, 2], to_tracker) >= np.cos(cell.acceptance_rad)
    if cell.floor_mm is not None:
        lowest = np.minimum(base2tool[:, 2, 3], link[:, 4:, 2, 3].min(axis=1))
        ok &= lowest >= cell.floor_mm
    return ok


@dataclass(frozen=True)
class Observability:
    """The identification Jacobian's pose blocks, for choosing and scoring poses.

    Attributes
    ----------
    names : tuple of str
        Parameters the blocks' columns belong to (those the model can identify).
    blocks : ndarray, shape (N, 3, P)
        Position rows of each pose (mm per mm, or per mm-equivalent: angle
        columns divided by :data:`ANGLE_SCALE_MM`).
    """

    names: tuple
    blocks: np.ndarray


def observability(mdh, q, flange2tool=None, frame="tracker", tool_known=False) -> Observability:
    """Scaled identification Jacobian of each pose (position rows), nominal arm.

    The free set is the one ``identify`` starts from
    (:func:`calibrator.identify.freeset.decide` without a session: Hayati's
    structural candidates less the model's own redundancies); which of them
    the measured poses then pin down is decided at identification.
    """
    from calibrator.identify import freeset

    q = np.atleast_2d(np.asarray(q, dtype=float))
    tool = np.eye(4) if flange2tool is None else np.asarray(flange2tool, dtype=float)
    free = freeset.decide(mdh, frame, tool_known, False, tool0=tool)
    kept = free.names
    space = free.space
    pose = measurement.predict(space, np.zeros(space.size), q)
    obs = measurement.Observations(q, pose[:, :3, 3])
    jac = measurement.jacobian(space, np.zeros(space.size), obs)
    scale = np.array([1.0 / ANGLE_SCALE_MM if parameters.unit(n) == "rad" else 1.0 for n in kept])
    blocks = (jac * scale).reshape(len(q), 3, len(kept))
    return Observability(tuple(kept), blocks)


def log_det(blocks) -> float:
    """D-optimality criterion: ``log det(J^T J)`` of stacked blocks (N, 3, P); -inf if singular."""
    jac = np.asarray(blocks).reshape(-1, np.shape(blocks)[-1])
    sign, value = np.linalg.slogdet(jac.T @ jac)
    return float(value) if sign > 0 else -np.inf


def min_singular(blocks) -> float:
    """Smallest singular value of the stacked blocks (N, 3, P) (observability index O3)."""
    jac = np.asarray(blocks).reshape(-1, np.shape(blocks)[-1])
    return float(np.linalg.svd(jac, compute_uv=False)[-1])


def select_d_optimal(blocks, n) -> np.ndarray:
    """Greedy D-optimal choice of ``n`` poses from blocks (C, 3, P); indices in pick order.

    Each step adds the candidate with the largest ``log det(I + J_c M^-1 J_c^T)``
    (the increase of ``log det M`` by the matrix determinant lemma), with
    ``M`` the information matrix of the poses picked so far plus a small ridge.
    """
    blocks = np.asarray(blocks, dtype=float)
    c, _, p = blocks.shape
    if n > c:
        raise PlanError(f"{n} poses asked, only {c} candidates satisfy the cell's constraints")
    ridge = 1e-9 * np.einsum("ckp,ckp->", blocks, blocks) / c
    info = ridge * np.eye(p)
    chosen = np.zeros(c, dtype=bool)
    picks = []
    for _ in range(n):
        solved = np.linalg.solve(info, blocks.reshape(-1, p).T).T.reshape(c, 3, p)
        gain_mat = np.eye(3) + np.einsum("ckp,cjp->ckj", blocks, solved)
        gain = np.linalg.slogdet(gain_mat)[1]
        gain[chosen] = -np.inf
        best = int(np.argmax(gain))
        chosen[best] = True
        picks.append(best)
        info = info + blocks[best].T @ blocks[best]
    return np.array(picks)


def make(
    mdh,
    joint_limits_rad,
    n,
    cell: CellConstraints = CellConstraints(),
    *,
    candidates=None,
    n_candidates=None,
    method="halton",
    selection="d-optimal",
    seed=0,
) -> np.ndarray:
    """A plan of ``n`` poses, shape (n, 6), rad.

    Parameters
    ----------
    mdh : array_like, shape (6, 5)
        Nominal MDH table.
    joint_limits_rad : array_like, shape (6, 2)
    n : int
    cell : CellConstraints
    candidates : array_like, shape (C, 6), optional
        The user's joint vectors (rad) instead of sampled ones.
    n_candidates : int, optional
        Sampled candidates; default ``max(60 n, 2000)`` (the acceptance cone
        keeps roughly one in ten).
    method : {'halton', 'random'}
    selection : {'d-optimal', 'random', 'first'}
        How ``n`` are chosen among the feasible candidates.
    seed : int
    """
    if selection not in SELECTIONS:
        raise PlanError(f"unknown selection {selection!r}; use one of {', '.join(SELECTIONS)}")
    box = joint_box(joint_limits_rad, cell.margin_rad)
    if candidates is None:
        pool = sample(box, n_candidates or max(60 * n, 2000), method, seed)
    else:
        pool = np.asarray(candidates, dtype=float)
        inside = np.all((pool >= box[:, 0]) & (pool <= box[:, 1]), axis=1)
        pool = pool[inside]
    pool = pool[feasible(mdh, pool, cell)]
    if len(pool) < n:
        raise PlanError(
            f"only {len(pool)} candidate poses satisfy the limits, margin, acceptance angle "
            f"and floor; {n} asked (more candidates, a wider angle or a lower floor?)"
        )
    if selection == "first":
        return pool[:n]
    if selection == "random":
        return pool[np.random.default_rng(seed).choice(len(pool), n, replace=False)]
    blocks = observability(mdh, pool, cell.flange2tool).blocks
    return pool[select_d_optimal(blocks, n)]


def min_poses(mdh, frame="tracker", tool_known=False) -> int:
    """Fewest poses whose position rows can determine the identifiable parameters."""
    from calibrator.identify import freeset

    return -(-len(freeset.decide(mdh, frame, tool_known, False).names) // 3)


def validate(q, joint_limits_rad, *, need=0) -> np.ndarray:
    """Check a whole plan before any motion: shape, finite, inside limits, enough poses.

    Returns
    -------
    ndarray, shape (N, 6)

    Raises
    ------
    PlanError
        Naming the first offending row and joint, or the shortfall.
    """
    q = np.asarray(q, dtype=float)
    if q.ndim != 2 or q.shape[1] != 6:
        raise PlanError(f"a plan needs 6 joint angles per pose, got shape {q.shape}")
    limits = np.asarray(joint_limits_rad, dtype=float)
    bad = ~((q >= limits[:, 0]) & (q <= limits[:, 1]))  # NaN fails both
    if bad.any():
        row, joint = np.argwhere(bad)[0]
        raise PlanError(
            f"plan row {row} joint {joint + 1}: {q[row, joint]:.6g} rad outside "
            f"[{limits[joint, 0]:.6g}, {limits[joint, 1]:.6g}]; nothing moved"
        )
    if len(q) < need:
        raise PlanError(f"plan has {len(q)} poses; the free parameters need at least {need}")
    return q


def digest(q) -> str:
    """SHA-256 of a plan's joint angles (what ties a journal to its plan)."""
    return hashlib.sha256(np.ascontiguousarray(q, dtype="<f8").tobytes()).hexdigest()


def read_csv(path) -> np.ndarray:
    """Joint angles from a CSV with columns ``q1_rad..q6_rad`` (or ``q1_deg..q6_deg``).

    Numbers follow the strict grammar of :func:`calibrator.strict.parse_number`
    (``0_5``, ``0x1``, ``nan`` are refused, not read). Other columns (``pose``,
    notes) are ignored, except joint columns beyond the six used (``q7_rad``,
    or a ``q2_deg`` beside ``q1_rad..q6_rad``): those mean another arm or a
    mix-up, and are refused.

    Returns
    -------
    ndarray, shape (N, 6)
        Joint angles (rad).

    Raises
    ------
    PlanError
        Missing file or columns, repeated, ambiguous or extra joint columns,
        a row longer than the header, a value outside the number grammar,
        no rows, or the same pose twice (a plan of repeated poses measures
        nothing new; its rows are named).
    """
    path = Path(path)
    try:
        with open(path, newline="", encoding="utf-8") as fh:
            reader = csv.DictReader(fh)
            fields = reader.fieldnames or []
            rows = list(reader)
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise PlanError(f"cannot read plan {path}: {exc}") from None
    repeated = sorted({c for c in fields if fields.count(c) > 1})
    if repeated:
        # DictReader would silently keep the last of the repeated columns.
        raise PlanError(f"{path}: repeated column(s) {', '.join(repeated)}")
    if all(c in fields for c in JOINT_COLUMNS) and all(c in fields for c in DEG_COLUMNS):
        raise PlanError(f"{path}: both q1_rad..q6_rad and q1_deg..q6_deg; keep one set")
    if any(None in r for r in rows):
        # DictReader files the values beyond the header under None.
        raise PlanError(f"{path}: a row has more values than the header")
    if all(c in fields for c in JOINT_COLUMNS):
        columns, factor = JOINT_COLUMNS, 1.0
    elif all(c in fields for c in DEG_COLUMNS):
        columns, factor = DEG_COLUMNS, np.pi / 180.0
    else:
        raise PlanError(f"{path}: needs columns {','.join(JOINT_COLUMNS)} (or q1_deg..q6_deg)")
    extra = [c for c in fields if _JOINT_LIKE.fullmatch(c.strip()) and c not in columns]
    if extra:
        raise PlanError(
            f"{path}: joint column(s) {', '.join(extra)} beside {columns[0]}..{columns[-1]}: "
            "a plan is for a 6-axis arm in one unit"
        )
    if not rows:
        raise PlanError(f"{path}: the plan has no poses")
    try:
        q = strict.parse_columns([[r[c] for c in columns] for r in rows], columns, str(path))
    except strict.StrictError as exc:
        raise PlanError(str(exc)) from None
    q = q * factor
    _refuse_repeats(q, path)
    return q


#: A joint column of any index and unit (``q7_rad``, ``Q1_DEG``).
_JOINT_LIKE = re.compile(r"[qQ]\d+_(?:rad|deg|RAD|DEG)")


def _refuse_repeats(q: np.ndarray, path: Path) -> None:
    """Refuse a pose that appears twice, naming the first pair of lines."""
    _, first, inverse = np.unique(q, axis=0, return_index=True, return_inverse=True)
    twice = np.flatnonzero(first[inverse.ravel()] != np.arange(len(q)))
    if twice.size:
        i = int(twice[0])
        j = int(first[inverse.ravel()[i]])
        distinct = len(first)
        raise PlanError(
            f"{path}: lines {j + 2} and {i + 2} are the same pose ({distinct} distinct of "
            f"{len(q)}); a repeated pose adds nothing to a calibration"
        )


def write_csv(path, q, inputs=()) -> None:
    """Write a plan (``pose,q1_rad..q6_rad``) atomically (:mod:`calibrator.outputs`).

    ``inputs`` are files the command read, which the plan must not overwrite.
    """
    from calibrator import outputs

    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(("pose", *JOINT_COLUMNS))
    for i, row in enumerate(np.asarray(q, dtype=float)):
        writer.writerow((i, *(repr(float(v)) for v in row)))
    outputs.write_text(path, buf.getvalue(), inputs=inputs)
