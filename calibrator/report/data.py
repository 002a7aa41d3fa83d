"""What the report shows, gathered from a calibration document and its session."""

from dataclasses import dataclass, field

import numpy as np

from calibrator import calibration, kinematics, parameters
from calibrator.errors import CalibrationError


@dataclass
class PoseErrors:
    """Per-pose position errors of the nominal and the identified model.

    Attributes
    ----------
    pose : ndarray of int, shape (N,)
        Pose numbers from the session.
    held_out : ndarray of bool, shape (N,)
        True for held-out (validation) poses, False for fitted ones.
    before_mm, after_mm : ndarray, shape (N,)
        Distance between model and measured tool point (mm): nominal MDH with
        the identification's first-guess frames, and the identified model.
    distance_mm : ndarray, shape (N,)
        Distance of the measured point from ``origin``.
    origin : str
        ``"tracker"``, or ``"robot base"`` for a base-frame session (where the
        tracker's position is not recorded).
    """

    pose: np.ndarray
    held_out: np.ndarray
    before_mm: np.ndarray
    after_mm: np.ndarray
    distance_mm: np.ndarray
    origin: str


@dataclass
class Content:
    """Everything on the page; ``None`` where the inputs do not hold it."""

    title: str
    facts: list  # (label, value) pairs
    stats: dict
    deltas: dict  # name -> value (mm or rad)
    standard_errors: dict | None
    dropped: list
    convergence: np.ndarray | None  # (G, 2): generation, best cost
    poses: PoseErrors | None
    warnings: list = field(default_factory=list)
    notes: dict = field(default_factory=dict)  # plot name -> why it is missing


def unit_of(name):
    """Unit of a parameter delta, ``'mm'`` or ``'rad'`` (also for names not known here)."""
    try:
        return parameters.unit(name)
    except KeyError:
        rotation = name.startswith(("alpha", "theta", "beta")) or name.endswith(
            ("_rx", "_ry", "_rz")
        )
        return "rad" if rotation else "mm"


def collect(doc, session=None, calibration_path=None, session_path=None):
    """Gather the report's content.

    Raises
    ------
    CalibrationError
        If ``session`` cannot be the session ``doc`` was identified from.
    """
    name = calibration_path or "the calibration"
    try:
        return _collect(doc, session, calibration_path, session_path)
    except KeyError as exc:
        raise CalibrationError(f"{name}: no {exc} entry, needed for the report") from None
    except (TypeError, ValueError, AttributeError) as exc:
        raise CalibrationError(f"{name}: malformed for the report ({exc})") from None


def _collect(doc, session, calibration_path, session_path):
    solver = doc.get("solver") or {}
    errors = (
        (doc.get("uncertainty") or {}).get("standard_errors")
        or doc.get("standard_errors")
        or solver.get("standard_errors")
    )
    curve = _curve(solver.get("convergence", doc.get("convergence")))
    facts = [
        ("calibration", calibration_path or "(in memory)"),
        ("session", session_path or doc.get("session") or "not recorded"),
        ("model", doc.get("model") or "nominal table in the session"),
        ("method", doc.get("method", "not recorded")),
        ("orientation weight k (mm^2/rad^2)", doc.get("k", "not recorded")),
        ("validation fraction", doc.get("validation_fraction", "not recorded")),
        ("seed", doc.get("seed", "not recorded")),
    ]
    content = Content(
        title=f"Calibration of {doc.get('model') or 'a robot arm'}",
        facts=facts,
        stats=doc.get("stats") or {},
        deltas={str(k): float(v) for k, v in (doc.get("deltas") or {}).items()},
        standard_errors={str(k): float(v) for k, v in errors.items()} if errors else None,
        dropped=list(doc.get("dropped_parameters") or []),
        convergence=curve,
        poses=None,
        warnings=[str(w) for w in doc.get("warnings") or []],
    )
    if doc.get("outlier_poses"):
        facts.append(("outlier poses set aside", ", ".join(map(str, doc["outlier_poses"]))))
    if content.convergence is None:
        content.notes["convergence"] = "not recorded (no swarm, or an older calibration file)"
    if session is None:
        why = "give the session file to draw per-pose errors"
        for name in ("pose_errors", "error_cdf", "error_vs_distance"):
            content.notes[name] = why
    else:
        content.poses = pose_errors(doc, session, session_path)
    return content


def _curve(curve):
    """The convergence curve as (G, 2) generation/best-cost rows.

    Accepts ``[[generation, cost], ...]`` (possibly thinned) or a plain list
    of costs, one per generation from 0.
    """
    if not curve:
        return None
    values = np.asarray(curve, dtype=float)
    if values.ndim == 1:
        return np.column_stack([np.arange(values.size), values])
    if values.ndim != 2 or values.shape[1] != 2:
        raise ValueError("'convergence' is neither costs nor [generation, cost] pairs")
    return values


def pose_errors(doc, session, session_path=None):
    """Per-pose errors of the nominal and identified models on ``session``.

    The nominal model is placed with the same first guess of ``base2tracker``
    and ``flange2tool`` as the identification started from, so the
    "before" numbers match the document's ``stats``.

    Returns
    -------
    PoseErrors
    """
    from calibrator.identify import initial

    obs = session.observations
    n = len(obs)
    stats = doc.get("stats") or {}
    expected = sum(stats.get(p, {}).get("before", {}).get("n", 0) for p in ("fit", "validation"))
    held = np.asarray(doc.get("validation_poses") or [], dtype=int)
    name = session_path or "the session"
    if (expected and n != expected) or (held.size and held.max() >= n):
        raise CalibrationError(
            f"{name} has {n} poses but the calibration was identified from {expected}: "
            "give the session it was made from"
        )
    held_out = np.zeros(n, dtype=bool)
    held_out[held] = True
    nominal = np.asarray(doc["nominal_mdh"], dtype=float)
    mdh = calibration.mdh_from_records(doc["mdh"])
    names = set(doc.get("free_parameters") or []) | {
        d["name"] for d in doc.get("dropped_parameters") or []
    }
    tool_known = not names.intersection(parameters.TOOL_NAMES)
    meta = session.meta
    base0, tool0 = initial.first_guess(
        nominal, obs.subset(np.flatnonzero(~held_out)), meta.flange2tool, meta.frame, tool_known
    )
    before = kinematics.forward(nominal, obs.q, tool0, base0)[:, :3, 3] - obs.points
    after = (
        kinematics.forward(
            mdh, obs.q, np.asarray(doc["flange2tool"]), np.asarray(doc["base2tracker"])
        )[:, :3, 3]
        - obs.points
    )
    origin = "tracker" if meta.frame == "tracker" else "robot base"
    return PoseErrors(
        pose=np.asarray(session.table["pose"].to_pylist(), dtype=int),
        held_out=held_out,
        before_mm=np.linalg.norm(before, axis=1),
        after_mm=np.linalg.norm(after, axis=1),
        distance_mm=np.linalg.norm(obs.points, axis=1),
        origin=origin,
    )
