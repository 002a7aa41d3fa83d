"""What the report shows, gathered from a calibration and its session."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from calibrator import calibration
from calibrator.errors import CalibrationError
from calibrator.model import kinematics, parameters

if TYPE_CHECKING:
    from calibrator.fit_records import FitStats
    from calibrator.session import Session


@dataclass(frozen=True)
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


@dataclass(frozen=True)
class Content:
    """Everything on the page; ``None`` where the inputs do not hold it."""

    title: str
    facts: list  # (label, value) pairs
    stats: FitStats
    deltas: dict  # name -> value (mm or rad)
    standard_errors: dict | None
    dropped: list
    convergence: np.ndarray | None  # (G, 2): generation, best cost
    poses: PoseErrors | None
    warnings: list = field(default_factory=list)
    notes: dict = field(default_factory=dict)  # plot name -> why it is missing
    #: Records of the free parameters (:meth:`Calibration.parameter_records`).
    parameters: list = field(default_factory=list)


def unit_of(name: str) -> str:
    """Unit of a parameter delta, ``'mm'`` or ``'rad'`` (also for names not known here)."""
    try:
        return parameters.unit(name)
    except KeyError:
        rotation = name.startswith(("alpha", "theta", "beta")) or name.endswith(
            ("_rx", "_ry", "_rz")
        )
        return "rad" if rotation else "mm"


def collect(
    cal: calibration.Calibration,
    session: Session | None = None,
    calibration_path: str | Path | None = None,
    session_path: str | Path | None = None,
) -> Content:
    """Gather the report's content.

    Parameters
    ----------
    cal : calibrator.calibration.Calibration
    session : calibrator.session.Session, optional
        The session ``cal`` was identified from (for the per-pose plots and
        what the measurement recorded: date, devices, readings per pose).
    calibration_path, session_path : str or Path, optional
        Shown on the page.

    Raises
    ------
    CalibrationError
        If ``session`` cannot be the session ``cal`` was identified from, or
        a recorded entry is malformed.
    """
    name = calibration_path or "the calibration"
    try:
        return _collect(cal, session, calibration_path, session_path)
    except KeyError as exc:
        raise CalibrationError(f"{name}: no {exc} entry, needed for the report") from None
    except (TypeError, ValueError, AttributeError) as exc:
        raise CalibrationError(f"{name}: malformed for the report ({exc})") from None


def _collect(cal, session, calibration_path, session_path):
    fit, origin = cal.fit, cal.provenance
    options = origin.recorded()
    solver = fit.solver
    unc = fit.uncertainty
    errors = unc.get("standard_errors") or cal.diagnostics.get("standard_errors")
    errors = errors or solver.get("standard_errors")
    curve = _curve(solver.get("convergence", cal.diagnostics.get("convergence")))
    facts = [
        ("calibration", calibration_path or "(in memory)"),
        ("session", session_path or cal.session or "not recorded"),
        ("model", cal.model or "nominal table in the session"),
        ("method", _recorded(options.get("method"))),
        ("loss", _recorded(options.get("loss"))),
        ("orientation weight k (mm^2/rad^2)", _recorded(options.get("k"))),
        ("validation fraction", _recorded(options.get("validation_fraction"))),
        ("seed", _recorded(options.get("seed"))),
    ]
    facts += _fit_facts(unc)
    if fit.outliers:
        facts.append(("outlier poses set aside", ", ".join(map(str, fit.outliers))))
    if origin.created:
        facts.append(("identified (UTC)", origin.created))
    if session is not None:
        facts += _session_facts(session)
    notes = {}
    if curve is None:
        notes["convergence"] = "not recorded (no swarm, or an older calibration file)"
    poses = None
    if session is None:
        why = "give the session file to draw per-pose errors"
        for plot in ("pose_errors", "error_cdf", "error_vs_distance"):
            notes[plot] = why
    else:
        poses = pose_errors(cal, session, session_path)
    return Content(
        title=f"Calibration of {cal.model or 'a robot arm'}",
        facts=facts,
        stats=fit.stats,
        deltas={str(k): float(v) for k, v in cal.deltas.items()},
        standard_errors={str(k): float(v) for k, v in errors.items()} if errors else None,
        dropped=list(cal.dropped),
        convergence=curve,
        poses=poses,
        warnings=[str(w) for w in fit.warnings],
        notes=notes,
        parameters=[r for r in cal.parameter_records() if r["free"]],
    )


def _recorded(value):
    return "not recorded" if value is None else value


def _fit_facts(unc):
    """Residual sigma, predicted held-out error and strongly correlated pairs."""
    facts = []
    sigma = unc.get("residual_sigma") or {}
    if sigma.get("position_mm") is not None:
        text = f"{sigma['position_mm']:.4f} mm per axis"
        if sigma.get("orientation_rad") is not None:
            text += f", {1000 * sigma['orientation_rad']:.4f} mrad"
        facts.append(("residual sigma", text))
    pred = unc.get("predicted_validation_mm")
    if pred:
        facts.append(("predicted held-out position error", f"{pred['error_mean']:.4f} mm mean"))
    strong = unc.get("strong_correlations")
    if strong is not None:
        pairs = ", ".join(f"{p['a']}/{p['b']} {p['r']:+.2f}" for p in strong) or "none"
        facts.append(("strongly correlated pairs (|r| > 0.9)", pairs))
    return facts


def _session_facts(session):
    """Date, devices and readings per pose, as far as the session records them."""
    facts = []
    table = session.table
    if "timestamp" in table.column_names:
        stamps = [t for t in table["timestamp"].to_pylist() if t is not None]
        if stamps:
            facts.append(("measured", f"{min(stamps)} to {max(stamps)}"))
    measured = session.meta.extra.get("measured") or {}
    for device in ("robot", "tracker"):
        facts.append((device, measured.get(device) or "not recorded"))
    if "n_readings" in table.column_names:
        counts = [n for n in table["n_readings"].to_pylist() if n is not None]
        if counts:
            low, high = min(counts), max(counts)
            facts.append(("readings per pose", str(low) if low == high else f"{low} to {high}"))
    return facts + _condition_facts(session.conditions())


def _condition_facts(said):
    """The measuring conditions the session recorded (session.conditions()), as report facts."""

    def span(column, unit, digits):
        low, high = said[column]["min"], said[column]["max"]
        if round(low, digits) == round(high, digits):
            return f"{low:.{digits}f} {unit}"
        return f"{low:.{digits}f} to {high:.{digits}f} {unit}"

    facts = []
    air = [
        span(c, u, d)
        for c, u, d in (
            ("air_temperature_c", "°C", 1),
            ("air_pressure_hpa", "hPa", 1),
            ("air_humidity_pct", "%RH", 0),
        )
        if c in said
    ]
    if air:
        facts.append(("air at the tracker", ", ".join(air)))
    if "tracker_warmed_up" in said or "tracker_on_s" in said:
        on = said.get("tracker_on_s")
        text = {True: "warmed up", False: "NOT warmed up", None: "warm-up not reported"}[
            said.get("tracker_warmed_up")
        ]
        if on:
            low, high = round(on["min"] / 60), round(on["max"] / 60)
            text += f", on for {low} min" if low == high else f", on for {low} to {high} min"
        facts.append(("tracker warm-up", text))
    joints = [
        f"J{j} {span(f'j{j}_temperature_c', '°C', 1)}"
        for j in range(1, 7)
        if f"j{j}_temperature_c" in said
    ]
    if joints:
        facts.append(("joint temperatures", ", ".join(joints)))
    return facts


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


def pose_errors(
    cal: calibration.Calibration, session: Session, session_path: str | Path | None = None
) -> PoseErrors:
    """Per-pose errors of the nominal and identified models on ``session``.

    The nominal model is placed with the same first guess of ``base2tracker``
    and ``flange2tool`` as the identification started from, so the
    "before" numbers match the calibration's ``stats``.

    Returns
    -------
    PoseErrors
    """
    from calibrator.identify import initial

    obs = session.observations
    n = len(obs)
    stats = cal.fit.stats
    # A hand-written or older file may lack any level: count what it records.
    parts = [part for part in (stats.get("fit"), stats.get("validation")) if part]
    expected = sum(part.get("before", {}).get("n", 0) for part in parts)
    held = np.asarray(cal.fit.validation_poses, dtype=int)
    name = session_path or "the session"
    if (expected and n != expected) or (held.size and held.max() >= n):
        raise CalibrationError(
            f"{name} has {n} poses but the calibration was identified from {expected}: "
            "give the session it was made from"
        )
    held_out = np.zeros(n, dtype=bool)
    held_out[held] = True
    recorded = cal.provenance.recorded()
    if "tool_known" in recorded:
        tool_known = recorded["tool_known"]
    else:
        names = set(cal.free) | {d["name"] for d in cal.dropped}
        tool_known = not names.intersection(parameters.TOOL_NAMES)
    meta = session.meta
    base0, tool0 = initial.first_guess(
        cal.nominal_mdh,
        obs.subset(np.flatnonzero(~held_out)),
        meta.flange2tool,
        meta.frame,
        tool_known,
    )
    before = kinematics.forward(cal.nominal_mdh, obs.q, tool0, base0)[:, :3, 3] - obs.points
    after = kinematics.forward(cal.mdh, obs.q, cal.flange2tool, cal.base2tracker)[:, :3, 3]
    after = after - obs.points
    origin = "tracker" if meta.frame == "tracker" else "robot base"
    return PoseErrors(
        pose=np.asarray(session.table["pose"].to_pylist(), dtype=int),
        held_out=held_out,
        before_mm=np.linalg.norm(before, axis=1),
        after_mm=np.linalg.norm(after, axis=1),
        distance_mm=np.linalg.norm(obs.points, axis=1),
        origin=origin,
    )
