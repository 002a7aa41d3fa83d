"""Plan files: the CSV a user writes or ``calibrator plan`` writes, read and written.

Columns ``q1_rad..q6_rad`` (or ``q1_deg..q6_deg``), an optional ``via`` column
(1: moved through, not measured) and, in files ``calibrator plan`` writes, the
:data:`ORIGIN_COLUMNS` recording the arm, tracker and tool the plan was made
for (:func:`made_for` refuses a run it was not made for). Numbers follow the
strict grammar of :mod:`calibrator.inputs.grammar`.

Joint angles rad, positions mm in the robot base frame (tracker) or on the
flange (tool).

Joint angles at the boundary: a plan file holds the angles the arm's
controller shows (KUKA's A1..A6, FANUC's J1..J6 with J3 from the horizon),
as its program and pendant do; a :class:`Plan` in memory holds the model's,
the kinematics' own. The ``joints`` column says which a file holds
(``controller``; ``model`` only in files written by earlier versions, which
had no such column but a ``model`` one, and are read as such). The arm's
convention is the file's ``model`` column's, else the arm the caller names.
"""

from __future__ import annotations

import csv
import io
import os
import re
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from calibrator.inputs import grammar, messages
from calibrator.inputs.errors import StrictError
from calibrator.model import DEFAULT_TOOL_MM
from calibrator.planning.plan import Plan, PlanError, PlanOrigin, point, point_text

JOINT_COLUMNS = tuple(f"q{i}_rad" for i in range(1, 7))
DEG_COLUMNS = tuple(f"q{i}_deg" for i in range(1, 7))

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
#: The column saying which joint angles a plan file holds (:data:`JOINTS`).
JOINTS_COLUMN = "joints"
#: The values of :data:`JOINTS_COLUMN`: the controller's angles, or the model's.
JOINTS = ("controller", "model")
#: Column of a plan file made with guessed collision geometry (a URDF's meshes
#: missing), after the :data:`ORIGIN_COLUMNS`: ``guessed: <what>`` on every row.
GEOMETRY_COLUMN = "geometry"
#: A run's tracker farther than this from the plan's is another cell, mm (the
#: whole-plan check then re-checks every aim with the run's position anyway).
ORIGIN_TOLERANCE_MM = 50.0


def read_csv(
    path: str | os.PathLike[str], arm: Any = None, *, _allow_via: bool = False
) -> np.ndarray:
    """The model's joint angles from a CSV with columns ``q1_rad..q6_rad`` (or ``q1_deg..q6_deg``).

    The file's angles are the controller's (:func:`joints_convention`): ``arm``
    (a :class:`calibrator.robots.RobotDescription`) is the arm they are for
    when the file does not name it.

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
    return joints_convention(fields, rows, path, arm).to_model(q)


def joints_convention(fields: Sequence[str], rows: list[dict], path: Any, arm: Any) -> Any:
    """The convention turning a plan file's angles into the model's.

    Parameters
    ----------
    fields, rows : the file's header and rows (:class:`csv.DictReader`)
    path : the file, for messages
    arm : calibrator.robots.RobotDescription or None
        The arm the caller runs (used when the file names none).

    Returns
    -------
    calibrator.robots.JointConvention
        Identity for model angles, or an arm whose controller shows its model's.
    """
    from calibrator import robots

    stated = (
        {str(r.get(JOINTS_COLUMN, "")).strip() for r in rows} if JOINTS_COLUMN in fields else set()
    )
    if len(stated) > 1 or (stated and not stated <= set(JOINTS)):
        raise PlanError(
            f"{path}: column {JOINTS_COLUMN} must be one of {', '.join(JOINTS)} on every row, "
            f"got {', '.join(sorted(stated))}"
        )
    joints = stated.pop() if stated else ("model" if "model" in fields else "controller")
    if joints == "model":
        return robots.JointConvention()
    names = {str(r.get("model", "")).strip() for r in rows} if "model" in fields else set()
    name = next(iter(names)) if len(names) == 1 else ""
    if name:
        try:
            return robots.get(name).convention
        except robots.DescriptionError:
            pass  # made_for() names the mismatch with the run's arm
    return arm.convention if arm is not None else robots.JointConvention()


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


_VIA_VALUES = {"0": False, "1": True}


def read_plan(path: str | os.PathLike[str], arm: Any = None) -> Plan:
    """A :class:`Plan` from a CSV: ``q1_rad..q6_rad`` (or degrees) and an optional ``via`` column.

    The file's angles are the controller's; the plan's, the model's
    (:func:`joints_convention`; ``arm`` is the caller's arm, for files that
    name none).

    Rows with ``via`` 1 are moved through, not measured, before the next
    measured row; ``via`` 0 (or no column) rows are measured, numbered in order.

    Raises
    ------
    PlanError
        Everything :func:`read_csv` refuses; a ``via`` value other than 0 or 1;
        via rows after the last measured pose.
    """
    q, via = _read_rows(path, arm)
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
        records = list(reader)
        rows = {tuple(str(r[c]).strip() for c in ORIGIN_COLUMNS) for r in records}
        guessed = str(records[0].get(GEOMETRY_COLUMN) or "").strip() if records else ""
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
        guessed.removeprefix("guessed:").strip()[:500] or None,
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
    tracker = None if tracker_at_mm is None else point(tracker_at_mm)
    tool = None if tool_mm is None else point(tool_mm)
    origin = plan.origin
    if origin is None:
        return tracker, tool if tool is not None else DEFAULT_TOOL_MM
    if origin.model.strip().lower() != model.name.strip().lower():
        raise PlanError(
            f"{source} was made for {messages.a_or_an(origin.model)}, not "
            f"{messages.a_or_an(model.name)} (--model): make a plan "
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


def _apart(a: ArrayLike, b: ArrayLike) -> bool:
    return bool(np.linalg.norm(np.subtract(a, b)) > ORIGIN_TOLERANCE_MM)


def _read_rows(path, arm) -> tuple[np.ndarray, np.ndarray]:
    """All rows' model joint angles (M, 6) rad and the via mask (M,) of a plan CSV."""
    q = read_csv(path, arm, _allow_via=True)
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
    path: str | os.PathLike[str],
    plan: Plan,
    inputs: Iterable[str | os.PathLike[str]] = (),
    arm: Any = None,
) -> None:
    """Write a :class:`Plan` (``pose,via,q1_rad..q6_rad``) atomically, in the controller's angles.

    A via row has an empty ``pose`` and ``via`` 1. A plan with an origin gets
    the :data:`ORIGIN_COLUMNS` too, the same on every row (the tracker's empty
    when unknown). ``inputs`` are files the command read, which the plan must
    not overwrite.
    """
    from calibrator import outputs

    outputs.write_text(path, plan_text(plan, arm), inputs=inputs)


def plan_text(plan: Plan, arm: Any = None) -> str:
    """A :class:`Plan` as the CSV text :func:`write_plan` writes.

    Joint columns are the controller's angles: the convention of the arm the
    plan's origin names, else of ``arm`` (identity when neither is given).
    """
    from calibrator import robots

    convention = arm.convention if arm is not None else robots.JointConvention()
    if plan.origin is not None:
        convention = robots.get(plan.origin.model).convention
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
    if plan.origin is not None and plan.origin.guessed_geometry:
        # Checked against a guess of the arm's shape: said on every row, as the origin is.
        origin += (f"guessed: {plan.origin.guessed_geometry}",)
    # Before the joints: a reader taking the last six columns still finds them there.
    columns = (*ORIGIN_COLUMNS, GEOMETRY_COLUMN)[: len(origin)]
    if origin:
        # Beside the model column, which alone marked earlier versions' model angles.
        origin += ("controller",)
        columns += (JOINTS_COLUMN,)
    writer.writerow(("pose", "via", *columns, *JOINT_COLUMNS))
    for i, (q, vias) in enumerate(zip(plan.q_rad, plan.via_rad, strict=True)):
        for v in convention.to_controller(vias):
            writer.writerow(("", 1, *origin, *(repr(float(x)) for x in v)))
        q_ctrl = convention.to_controller(q)
        writer.writerow((i, 0, *origin, *(repr(float(x)) for x in q_ctrl)))
    return buf.getvalue()
