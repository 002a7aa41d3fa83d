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
import os
import re
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from calibrator.cell.timing import CellTime
from calibrator.errors import CalibrationError
from calibrator.identify.halton import halton
from calibrator.inputs import grammar
from calibrator.inputs.errors import StrictError
from calibrator.model import kinematics, measurement, parameters

if TYPE_CHECKING:
    from calibrator import robots
    from calibrator.cell import Cell

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


def joint_box(joint_limits_rad: ArrayLike, margin_rad: float) -> np.ndarray:
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


def sample(box: np.ndarray, n: int, method: str = "halton", seed: int = 0) -> np.ndarray:
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


def feasible(mdh: ArrayLike, q: np.ndarray, cell: CellConstraints) -> np.ndarray:
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


def observability(
    mdh: np.ndarray,
    q: np.ndarray,
    flange2tool: ArrayLike | None = None,
    frame: str = "tracker",
    tool_known: bool = False,
    names: tuple | None = None,
) -> Observability:
    """Scaled identification Jacobian of each pose (position rows), nominal arm.

    The free set is the one ``identify`` starts from
    (:func:`calibrator.identify.freeset.decide` without a session: Hayati's
    structural candidates less the model's own redundancies); which of them
    the measured poses then pin down is decided at identification. ``names``
    (of :data:`calibrator.model.parameters.ALL_NAMES`) replaces it, e.g. with what
    drifts (``calibrator check``'s joint zeros, base and tool).
    """
    from calibrator.identify import freeset

    q = np.atleast_2d(np.asarray(q, dtype=float))
    tool = np.eye(4) if flange2tool is None else np.asarray(flange2tool, dtype=float)
    if names is None:
        free = freeset.decide(mdh, frame, tool_known, False, tool0=tool)
        kept, space = free.names, free.space
    else:
        space = parameters.ParameterSpace(np.asarray(mdh, float), tool0=tool, free=tuple(names))
        kept = space.free
    pose = measurement.predict(space, np.zeros(space.size), q)
    obs = measurement.Observations(q, pose[:, :3, 3])
    jac = measurement.jacobian(space, np.zeros(space.size), obs)
    scale = np.array([1.0 / ANGLE_SCALE_MM if parameters.unit(n) == "rad" else 1.0 for n in kept])
    blocks = (jac * scale).reshape(len(q), 3, len(kept))
    return Observability(tuple(kept), blocks)


def log_det(blocks: np.ndarray) -> float:
    """D-optimality criterion: ``log det(J^T J)`` of stacked blocks (N, 3, P); -inf if singular."""
    jac = np.asarray(blocks).reshape(-1, np.shape(blocks)[-1])
    sign, value = np.linalg.slogdet(jac.T @ jac)
    return float(value) if sign > 0 else -np.inf


def min_singular(blocks: np.ndarray) -> float:
    """Smallest singular value of the stacked blocks (N, 3, P) (observability index O3)."""
    jac = np.asarray(blocks).reshape(-1, np.shape(blocks)[-1])
    return float(np.linalg.svd(jac, compute_uv=False)[-1])


def select_d_optimal(blocks: np.ndarray, n: int) -> np.ndarray:
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
    mdh: np.ndarray,
    joint_limits_rad: ArrayLike,
    n: int,
    cell: CellConstraints = CellConstraints(),
    *,
    candidates: ArrayLike | None = None,
    n_candidates: int | None = None,
    method: str = "halton",
    selection: str = "d-optimal",
    seed: int = 0,
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


def min_poses(mdh: np.ndarray, frame: str = "tracker", tool_known: bool = False) -> int:
    """Fewest poses whose position rows can determine the identifiable parameters."""
    from calibrator.identify import freeset

    return -(-len(freeset.decide(mdh, frame, tool_known, False).names) // 3)


def validate(q: ArrayLike, joint_limits_rad: ArrayLike, *, need: int = 0) -> np.ndarray:
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


def digest(q: ArrayLike) -> str:
    """SHA-256 of a plan's joint angles (what ties a journal to its plan)."""
    return hashlib.sha256(np.ascontiguousarray(q, dtype="<f8").tobytes()).hexdigest()


def read_csv(path: str | os.PathLike[str], *, _allow_via: bool = False) -> np.ndarray:
    """Joint angles from a CSV with columns ``q1_rad..q6_rad`` (or ``q1_deg..q6_deg``).

    Numbers follow the strict grammar of :func:`calibrator.inputs.grammar.parse_number`
    (``0_5``, ``0x1``, ``nan`` are refused, not read). Other columns (``pose``,
    notes) are ignored, except joint columns beyond the six used (``q7_rad``,
    or a ``q2_deg`` beside ``q1_rad..q6_rad``): those mean another arm or a
    mix-up, and are refused. A pose measured twice is refused. A plan with via
    rows (a ``via`` column with a 1) is refused: its vias are no poses to
    measure; read it with :func:`read_plan`.

    Returns
    -------
    ndarray, shape (N, 6)
        Joint angles (rad); with ``_allow_via``, every row, vias included
        (repeats are then checked by :func:`read_plan` on the measured rows).

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
    if not _allow_via and "via" in fields and any(str(r["via"]).strip() != "0" for r in rows):
        raise PlanError(f"{path}: has via rows (moved through, not measured): read it as a Plan")
    try:
        q = grammar.parse_columns([[r[c] for c in columns] for r in rows], columns, str(path))
    except StrictError as exc:
        raise PlanError(str(exc)) from None
    q = q * factor
    if not _allow_via:
        _refuse_repeats(q, path)
    return q


#: A joint column of any index and unit (``q7_rad``, ``Q1_DEG``).
_JOINT_LIKE = re.compile(r"[qQ]\d+_(?:rad|deg|RAD|DEG)")


def _refuse_repeats(
    q: np.ndarray, path: str | os.PathLike[str], lines: np.ndarray | None = None
) -> None:
    """Refuse a pose that appears twice, naming the first pair of lines.

    ``lines`` are the file lines of the rows of ``q`` (default: row + 2, after
    the header), for plans whose vias sit between the measured rows.
    """
    lines = np.arange(len(q)) + 2 if lines is None else lines
    _, first, inverse = np.unique(q, axis=0, return_index=True, return_inverse=True)
    twice = np.flatnonzero(first[inverse.ravel()] != np.arange(len(q)))
    if twice.size:
        i = int(twice[0])
        j = int(first[inverse.ravel()[i]])
        distinct = len(first)
        raise PlanError(
            f"{path}: lines {lines[j]} and {lines[i]} are the same pose ({distinct} distinct of "
            f"{len(q)}); a repeated pose adds nothing to a calibration"
        )


def write_csv(
    path: str | os.PathLike[str], q: ArrayLike, inputs: Iterable[str | os.PathLike[str]] = ()
) -> None:
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


# ---- plans with via poses, checked in the cell and ordered for time


#: Reflector on the flange when neither the run nor the plan says, mm.
DEFAULT_TOOL_MM = (0.0, 0.0, 100.0)
#: Columns of a plan file that record what it was made for (the same on every row).
ORIGIN_COLUMNS = (
    "model",
    "model_sha256",
    "tracker_x_mm",
    "tracker_y_mm",
    "tracker_z_mm",
    "tool_x_mm",
    "tool_y_mm",
    "tool_z_mm",
)
#: A run's tracker farther than this from the plan's is another cell, mm (the
#: whole-plan check then re-checks every aim with the run's position anyway).
ORIGIN_TOLERANCE_MM = 50.0


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
    """

    model: str
    tool_mm: tuple[float, float, float]
    tracker_at_mm: tuple[float, float, float] | None = None
    model_sha256: str | None = None


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


_VIA_VALUES = {"0": False, "1": True}


def read_plan(path: str | os.PathLike[str]) -> Plan:
    """A :class:`Plan` from a CSV: ``q1_rad..q6_rad`` (or degrees) and an optional ``via`` column.

    Rows with ``via`` 1 are moved through, not measured, before the next
    measured row; ``via`` 0 (or no column) rows are measured, numbered in order.

    Raises
    ------
    PlanError
        Everything :func:`read_csv` refuses; a ``via`` value other than 0 or 1;
        via rows after the last measured pose.
    """
    q, via = _read_rows(path)
    origin = _read_origin(path)
    if via[-1]:
        raise PlanError(f"{path}: via rows after the last measured pose (they lead nowhere)")
    _refuse_repeats(q[~via], path, np.flatnonzero(~via) + 2)
    vias, pending = [], []
    for row, is_via in zip(q, via, strict=True):
        if is_via:
            pending.append(row)
        else:
            vias.append(np.array(pending).reshape(-1, 6))
            pending = []
    return Plan(q[~via], tuple(vias), origin)


def _read_origin(path) -> PlanOrigin | None:
    """The plan's :class:`PlanOrigin` from its :data:`ORIGIN_COLUMNS`, or None without them."""
    with open(path, newline="", encoding="utf-8") as fh:
        reader = csv.DictReader(fh)
        fields = reader.fieldnames or []
        if "model" not in fields:
            return None
        missing = [c for c in ORIGIN_COLUMNS if c not in fields]
        if missing:
            raise PlanError(f"{path}: has a model column but not {', '.join(missing)}")
        rows = {tuple(str(r[c]).strip() for c in ORIGIN_COLUMNS) for r in reader}
    if len(rows) != 1:
        raise PlanError(f"{path}: the model, tracker and tool columns differ between rows")
    model, digest, *numbers = rows.pop()
    if not model:
        raise PlanError(f"{path}: the model column is empty")
    if digest and not re.fullmatch(r"sha256:[0-9a-f]{64}", digest):
        raise PlanError(f"{path}: model_sha256 is not a sha256: digest: {digest[:80]!r}")
    tracker_text, tool_text = numbers[:3], numbers[3:]
    try:
        tool = grammar.parse_columns([tool_text], ORIGIN_COLUMNS[5:], str(path))[0]
        tracker = None
        if any(tracker_text):
            tracker = grammar.parse_columns([tracker_text], ORIGIN_COLUMNS[2:5], str(path))[0]
    except StrictError as exc:
        raise PlanError(str(exc)) from None
    # Points in a robot cell: a tool on the flange, a tracker in the room.
    for what, v, limit in (("tool", tool, 2_000.0), ("tracker", tracker, 100_000.0)):
        if v is not None and np.abs(v).max() > limit:
            raise PlanError(
                f"{path}: the {what} position {point_text(v)} mm is beyond +-{limit:g} mm"
            )
    return PlanOrigin(
        model,
        (float(tool[0]), float(tool[1]), float(tool[2])),
        None if tracker is None else (float(tracker[0]), float(tracker[1]), float(tracker[2])),
        digest or None,
    )


def made_for(
    plan: Plan,
    model: Any,
    tracker_at_mm: ArrayLike | None,
    tool_mm: ArrayLike | None,
    source: str | os.PathLike[str] = "the plan",
) -> tuple[tuple[float, float, float] | None, tuple[float, float, float]]:
    """The tracker position and tool a run of ``plan`` uses; a run it was not made for is refused.

    A plan's checks hold for the arm and tracker it was made for: a run on
    another arm, or with the tracker elsewhere, is refused naming both. The
    reflector is a first guess that identification corrects, so a run's
    ``--tool`` is taken as given (the whole-plan check runs with it). What the
    run does not give is taken from the plan.

    Parameters
    ----------
    plan : Plan
    model : calibrator.robots.RobotDescription
        The run's arm (``--model``).
    tracker_at_mm : array_like, shape (3,), optional
        The run's tracker position (``--tracker-at`` or the cell file's), base frame, mm.
    tool_mm : array_like, shape (3,), optional
        The run's reflector on the flange (``--tool``), mm.
    source : str or path
        The plan's file, for the message.

    Returns
    -------
    tracker_at_mm : tuple of 3 float or None
    tool_mm : tuple of 3 float

    Raises
    ------
    PlanError
        Another model (name or description digest), or a tracker farther than
        :data:`ORIGIN_TOLERANCE_MM`.
    """
    tracker = None if tracker_at_mm is None else _point(tracker_at_mm)
    tool = None if tool_mm is None else _point(tool_mm)
    origin = plan.origin
    if origin is None:
        return tracker, tool if tool is not None else DEFAULT_TOOL_MM
    if origin.model.strip().lower() != model.name.strip().lower():
        raise PlanError(
            f"{source} was made for a {origin.model}, not a {model.name} (--model): make a plan "
            "for this arm"
        )
    if origin.model_sha256 is not None and origin.model_sha256 != model.digest:
        raise PlanError(
            f"{source} was made for another description of the {origin.model} "
            f"({origin.model_sha256[:19]}, not {model.digest[:19]}): make a plan for this one"
        )
    if tracker is not None and origin.tracker_at_mm is not None:
        if _apart(tracker, origin.tracker_at_mm):
            raise PlanError(
                f"{source} was made for the tracker at {point_text(origin.tracker_at_mm)} mm, not "
                f"{point_text(tracker)} (--tracker-at or the cell file): make a plan for this cell"
            )
    return (
        tracker if tracker is not None else origin.tracker_at_mm,
        tool if tool is not None else origin.tool_mm,
    )


def _point(v: ArrayLike) -> tuple[float, float, float]:
    x, y, z = (float(c) for c in np.asarray(v, dtype=float).reshape(3))
    return x, y, z


def _apart(a: ArrayLike, b: ArrayLike) -> bool:
    return bool(np.linalg.norm(np.subtract(a, b)) > ORIGIN_TOLERANCE_MM)


def point_text(v: ArrayLike) -> str:
    """``x,y,z`` as the messages write a point (mm), e.g. ``2500,400,300``."""
    return ",".join(f"{c:g}" for c in np.asarray(v, dtype=float))


def _read_rows(path) -> tuple[np.ndarray, np.ndarray]:
    """All rows' joint angles (M, 6) rad and the via mask (M,) of a plan CSV."""
    q = read_csv(path, _allow_via=True)
    with open(path, newline="", encoding="utf-8") as fh:
        reader = csv.DictReader(fh)
        if "via" not in (reader.fieldnames or []):
            return q, np.zeros(len(q), dtype=bool)
        raw = [r["via"] for r in reader]
    bad = [i for i, v in enumerate(raw) if str(v).strip() not in _VIA_VALUES]
    if bad:
        raise PlanError(f"{path}: row {bad[0]}: via must be 0 or 1, got {raw[bad[0]]!r}")
    return q, np.array([_VIA_VALUES[str(v).strip()] for v in raw])


def write_plan(
    path: str | os.PathLike[str], plan: Plan, inputs: Iterable[str | os.PathLike[str]] = ()
) -> None:
    """Write a :class:`Plan` (``pose,via,q1_rad..q6_rad``) atomically.

    A via row has an empty ``pose`` and ``via`` 1. A plan with an origin gets
    the :data:`ORIGIN_COLUMNS` too, the same on every row (the tracker's empty
    when unknown). ``inputs`` are files the command read, which the plan must
    not overwrite.
    """
    from calibrator import outputs

    outputs.write_text(path, plan_text(plan), inputs=inputs)


def plan_text(plan: Plan) -> str:
    """A :class:`Plan` as the CSV text :func:`write_plan` writes."""
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    origin: tuple = ()
    if plan.origin is not None:
        o = plan.origin
        tracker = ("", "", "") if o.tracker_at_mm is None else o.tracker_at_mm
        origin = (
            o.model,
            o.model_sha256 or "",
            *(repr(float(v)) if v != "" else "" for v in tracker),
        )
        origin += tuple(repr(float(v)) for v in o.tool_mm)
    # Before the joints: a reader taking the last six columns still finds them there.
    writer.writerow(("pose", "via", *(ORIGIN_COLUMNS if origin else ()), *JOINT_COLUMNS))
    for i, (q, vias) in enumerate(zip(plan.q_rad, plan.via_rad, strict=True)):
        for v in vias:
            writer.writerow(("", 1, *origin, *(repr(float(x)) for x in v)))
        writer.writerow((i, 0, *origin, *(repr(float(x)) for x in q)))
    return buf.getvalue()


#: Candidates closer than this on every joint are one pose (rad).
DUPLICATE_RAD = 1e-4


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
    """

    plan: Plan
    candidates: int
    dropped: dict
    names: tuple
    blocks: np.ndarray
    selection_time: CellTime
    ordered_time: CellTime


def distinct(q: ArrayLike) -> np.ndarray:
    """Indices (sorted) of the first of each group of equal joint vectors of ``q`` (N, 6).

    Equal: within :data:`DUPLICATE_RAD` on every joint (a grid of that size).
    """
    q = np.asarray(q, dtype=float)
    if not len(q):
        return np.zeros(0, dtype=int)
    _, first = np.unique(np.round(q / DUPLICATE_RAD), axis=0, return_index=True)
    return np.sort(first)


def make_checked(
    model: robots.RobotDescription,
    n: int,
    cell: Cell,
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
    another order, else by two vias with the arm upright, else refused.

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
    method, selection, seed
        As :func:`make`.
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
        Too few candidates pass (with the counts per reason), the chosen
        poses cannot determine the parameters, or a move cannot be made safe.
    calibrator.cell.CellError
        The tracker is placed where the arm could reach it.
    """
    from calibrator import cell as cells

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
    # Any two poses must be joinable: through the arm upright if not directly. A pose
    # the arm cannot leave upwards safely (the shoulder past horizontal on the far
    # side, where the way up turns through the floor) is dropped and the choice made
    # again; checked on the chosen poses only (a motion check per candidate is slow).
    usable = np.ones(len(pool), dtype=bool)
    rng = np.random.default_rng(seed)
    while True:
        left = np.flatnonzero(usable)
        if len(left) < n:
            raise PlanError(
                f"only {len(left)} of {total} candidates pass the cell's checks and have a safe "
                f"way up; {n} asked (more candidates or another tracker position?)"
            )
        if selection == "first":
            picks = left[:n]
        elif selection == "random":
            picks = left[rng.permutation(len(left))[:n]]
        else:
            picks = left[select_d_optimal(obs.blocks[left], n)]
        stuck = picks[~_can_rise(chk, pool[picks])]
        if not stuck.size:
            break
        usable[stuck] = False
    dropped["no safe way up"] = int((~usable).sum())
    blocks = obs.blocks[picks]
    _check_rank(blocks, obs.names, n, len(pool))
    chosen = pool[picks]
    speed, accel = model.move_speed_cap_rad_s, model.move_accel_cap_rad_s2
    plan = _order_safely(chk, chosen, box, speed, accel)
    # What the plan's checks held for, recorded in its file (read_plan, made_for).
    at = cell.tracker_at_mm
    plan = Plan(
        plan.q_rad,
        plan.via_rad,
        PlanOrigin(model.name, _point(tool_mm), None if at is None else _point(at), model.digest),
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
    )


#: Most candidates :func:`make_checked` samples on its own.
MAX_SAMPLED = 400_000


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
    from calibrator import cell as cells

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


def _order_safely(chk, q: np.ndarray, box: np.ndarray, speed: float, accel: float) -> Plan:
    """The poses in a short-time order whose every move is safe, with vias where needed."""
    from calibrator import cell as cells

    times = cells.time_matrix(q, speed, accel)
    verdict: dict[tuple[int, int], np.ndarray] = {}
    order = cells.order_poses(times)
    for attempt in range(8):
        edges = list(zip(order[:-1].tolist(), order[1:].tolist(), strict=True))
        new = [e for e in edges if e not in verdict]
        if new:
            a, b = np.array(new).T
            faults = cells.motion_faults(chk, q[a], q[b])
            for e, f in zip(new, faults, strict=True):
                verdict[e] = verdict[e[::-1]] = f
        bad = [e for e in edges if verdict[e].any()]
        if not bad or attempt == 7:
            break  # every edge of this order has a verdict: vias below for the bad ones
        for a, b in bad:
            times[a, b] = times[b, a] = np.inf
        order = cells.order_poses(times)
    order = _close_safely(chk, q, order, times, verdict)
    vias = []
    for k, i in enumerate(order):
        if k == 0 or not verdict[(int(order[k - 1]), int(i))].any():
            vias.append(np.zeros((0, 6)))
            continue
        a, b = int(order[k - 1]), int(i)
        via = _upright_vias(chk, q[a], q[b], box)
        if via is None:
            reason = cells.MOTION_REASONS[int(np.argmax(verdict[(a, b)]))]
            raise PlanError(
                f"no safe move between poses {k - 1} and {k} ({reason} along the joint-space line) "
                "in any order tried, nor through the arm held upright; change the cell or the poses"
            )
        vias.append(via)
    return Plan(q[order], tuple(vias))


def _close_safely(
    chk, q: np.ndarray, order: np.ndarray, times: np.ndarray, verdict: dict
) -> np.ndarray:
    """``order`` turned so that the move from its last pose back to its first is safe.

    A program returns from the last pose to its home, by default the first
    pose, along the joint-space line: that closing move must pass the same
    checks as every other. If it does not, the cycle starts after its longest
    safe direct move instead (the old closing move becomes an inner one, given
    vias like any other). ``verdict`` maps ``(a, b)`` to the move's faults and
    gains the closing move's.
    """
    from calibrator import cell as cells

    if len(order) < 2:
        return order
    first, last = int(order[0]), int(order[-1])
    if (last, first) not in verdict:
        faults = cells.motion_faults(chk, q[last][None], q[first][None])[0]
        verdict[(last, first)] = verdict[(first, last)] = faults
    if not verdict[(last, first)].any():
        return order
    pairs = list(zip(order[:-1].tolist(), order[1:].tolist(), strict=True))
    safe = [k for k, e in enumerate(pairs) if not verdict[e].any()]
    if not safe:
        return order  # every move needs vias: the closing one is refused where it is used
    k = max(safe, key=lambda j: times[pairs[j]] if np.isfinite(times[pairs[j]]) else 0.0)
    return np.roll(order, -(k + 1))


def _rise_paths(chk, q: np.ndarray) -> list[np.ndarray]:
    """Ways up from each pose of ``q`` (N, 6): via lists (N, k, 6).

    Each ends with the arm upright and the wrist neutral (joints 1 and 6 as
    in ``q``), where turning joints 1 and 6 to another pose's is safe: shoulder
    and elbow together, elbow first, or shoulder first, then the wrist.
    """
    up2, up3 = chk.geometry.upright_rad
    upright = q.copy()
    upright[:, 1:3] = (up2, up3)
    neutral = upright.copy()
    neutral[:, 3:5] = chk.geometry.neutral_wrist_rad
    elbow, shoulder = q.copy(), q.copy()
    elbow[:, 2] = up3
    shoulder[:, 1] = up2
    return [
        np.stack([upright, neutral], 1),
        np.stack([elbow, upright, neutral], 1),
        np.stack([shoulder, upright, neutral], 1),
    ]


def _can_rise(chk, q: np.ndarray) -> np.ndarray:
    """Which poses of ``q`` (N, 6) have a safe way up (:func:`_rise_paths`), shape (N,) bool."""
    from calibrator import cell as cells

    ok = np.zeros(len(q), dtype=bool)
    for vias in _rise_paths(chk, q):
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
    from calibrator import cell as cells

    # Up from qa, across upright, down to qb (the way up reversed): each way up
    # of qa with each of qb, shortest first.
    ups_a = [v[0] for v in _rise_paths(chk, qa[None])]
    ups_b = [v[0][::-1] for v in _rise_paths(chk, qb[None])]
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
