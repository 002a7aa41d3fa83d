"""Opt-in joint terms on top of a geometric fit, kept only where cross-validation says so.

After :func:`calibrator.identify.pipeline.identify` has fitted the geometry,
:func:`fit` adds the requested joint-term groups (``scale``, ``harmonic``,
``compliance``, see :mod:`calibrator.model.joint_terms`):

1. the terms join the geometric free set in the *same* free-set decision
   (:func:`calibrator.identify.freeset.offer`: redundancy, then what these
   poses pin down against the noise): a term these poses
   cannot tell from the geometry, or cannot pin down against the noise, is
   dropped with the same kind of reason as a geometric parameter;
2. least squares from the geometric solution fits geometry and terms together;
3. each group is kept only when it lowers the cross-validated error (leave-one-
   out up to :data:`LOO_MAX_POSES` fitting poses, else :data:`FOLDS`-fold) of
   the objective's own per-pose error ``sqrt(|dp|^2 + k |dphi|^2)`` by more than
   :data:`MIN_GAIN`; groups are tried in the order given, each against the
   geometry plus the groups kept before it;
4. standard errors and the predicted held-out error come from the same
   :func:`calibrator.identify.uncertainty.analyse` as for the geometry.

Compliance needs the gravity torque of every pose (``Observations.torque``)
and more than one payload: at one payload a torque term is a smooth function
of the pose that the geometry absorbs.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np

from calibrator.fit_records import FitStats, Uncertainty
from calibrator.identify import accuracy, freeset, refine, uncertainty
from calibrator.identify.problem import Problem
from calibrator.model import joint_terms, measurement, parameters

if TYPE_CHECKING:
    from calibrator.identify.pipeline import Result
    from calibrator.model.mass_models import MassModel
    from calibrator.session import Session

#: Up to this many fitting poses cross-validation leaves one out at a time.
LOO_MAX_POSES = 40
#: Folds of the K-fold cross-validation above :data:`LOO_MAX_POSES`.
FOLDS = 10
#: Smallest relative drop of the cross-validated error for a group to be kept.
MIN_GAIN = 0.02
#: Payloads closer than this (kg) count as one.
PAYLOAD_TOL_KG = 0.1


@dataclass
class JointFit:
    """Outcome of :func:`fit`.

    Attributes
    ----------
    space : ParameterSpace
        Geometry plus the kept terms.
    x : ndarray, shape (space.size,)
    kept : tuple of str
        Kept groups.
    decisions : list of dict
        Per requested group: ``group``, ``kept``, ``reason``, ``cv_without``,
        ``cv_with`` (each ``{"score_mm", "position_mm", "orientation_deg"}``).
    dropped : list of dict
        Terms the free-set decision left out, ``{"name", "reason"}``.
    cv_geometry, cv_final : dict
        Cross-validated errors of the geometry alone and of the final model.
    uncertainty : calibrator.fit_records.Uncertainty
        :func:`calibrator.identify.uncertainty.analyse` of the final model.
    stats : calibrator.fit_records.FitStats
        Before/after statistics as in the pipeline's result.
    """

    space: parameters.ParameterSpace
    x: np.ndarray
    kept: tuple[str, ...]
    decisions: list[dict] = field(default_factory=list)
    dropped: list[dict] = field(default_factory=list)
    cv_geometry: dict = field(default_factory=dict)
    cv_final: dict = field(default_factory=dict)
    uncertainty: Uncertainty = field(default_factory=lambda: Uncertainty())
    stats: FitStats = field(default_factory=lambda: FitStats())

    @property
    def terms(self) -> joint_terms.JointTerms:
        """Values of every term (zeros where not kept)."""
        return joint_terms.JointTerms.from_vector(self.space.joint_terms(self.x))


def payloads(payload_kg: np.ndarray | None) -> np.ndarray:
    """Distinct payloads (kg) among the poses."""
    if payload_kg is None:
        return np.zeros(1)
    values = np.sort(np.asarray(payload_kg, dtype=float))
    return values[np.concatenate([[True], np.diff(values) > PAYLOAD_TOL_KG])]


def fit(
    problem: Problem,
    x: np.ndarray,
    validation: measurement.Observations,
    groups: tuple[str, ...],
    noise_mm: float,
    payload_kg: np.ndarray | None = None,
) -> JointFit:
    """Add joint-term groups to a geometric fit where they pay (see the module docstring).

    Parameters
    ----------
    problem : Problem
        The geometric fit's problem: free set, fitting poses (with ``torque``
        for compliance) and orientation weight (mm^2/rad^2).
    x : ndarray, shape (problem.space.size,)
        The geometric fit's deltas.
    validation : Observations
        Held-out poses (with ``torque`` for compliance).
    groups : tuple of str
        Requested groups, from :data:`calibrator.model.joint_terms.GROUPS`.
    noise_mm : float
        Noise per residual row assumed by the free-set decision.
    payload_kg : ndarray, shape (len(problem),), optional
        Payload of every fitting pose (kg).

    Returns
    -------
    JointFit
    """
    space, fit_obs = problem.space, problem.obs
    decisions, dropped = [], []
    usable = []
    for group in groups:
        if group == "compliance":
            if fit_obs.torque is None:
                decisions.append(_no(group, "no gravity torques (needs a mass model)"))
                continue
            if len(payloads(payload_kg)) < 2:
                decisions.append(
                    _no(
                        group,
                        "one payload only: compliance cannot be told from the geometry "
                        "(measure at two or more payloads)",
                    )
                )
                continue
        usable.append(group)
    # The same free-set decision as the geometry's: redundancy, then what these poses pin down.
    offered = freeset.offer(problem, x, joint_terms.names_of(tuple(usable)), noise_mm)
    kept_names = list(offered.names)
    dropped += [d for d in offered.dropped if d["name"] in joint_terms.NAMES]
    ext = problem.with_free(list(space.free) + [n for n in kept_names if n not in space.free])
    x_ext = _extend(space, x, ext.space)
    folds = _folds(len(fit_obs))

    def solve(free: list[str], obs: measurement.Observations) -> tuple:
        sp = ext.space.with_free(free)
        start = _extend(ext.space, x_ext, sp)
        return sp, refine.refine(Problem(sp, obs, problem.k), start).x

    # The geometry keeps its own free set: the swarm and least squares fitted it.
    current = list(space.free)
    cv_geometry = _cv(current, solve, fit_obs, problem.k, folds)
    cv_current = cv_geometry
    kept_groups = []
    for group in usable:
        group_names = [n for n in joint_terms.names_of((group,)) if n in kept_names]
        if not group_names:
            decisions.append(_no(group, "every term dropped by the free-set decision"))
            continue
        trial = current + group_names
        cv_trial = _cv(trial, solve, fit_obs, problem.k, folds)
        gain = 1.0 - cv_trial["score_mm"] / cv_current["score_mm"]
        keep = gain > MIN_GAIN
        how = _cv_text(len(fit_obs), folds)
        reason = (
            f"{how} error {cv_current['score_mm']:.4f} -> {cv_trial['score_mm']:.4f} mm "
            f"({100 * gain:+.1f} %; kept above {100 * MIN_GAIN:g} %)"
        )
        decisions.append(
            {
                "group": group,
                "kept": keep,
                "terms": group_names,
                "reason": reason,
                "cv_without": cv_current,
                "cv_with": cv_trial,
            }
        )
        if keep:
            current, cv_current = trial, cv_trial
            kept_groups.append(group)
    final_space, final_x = solve(current, fit_obs)
    unc = uncertainty.analyse(Problem(final_space, fit_obs, problem.k), final_x, validation)
    stats = accuracy.fit_stats(final_space, final_x, fit_obs, validation)
    return JointFit(
        final_space,
        final_x,
        tuple(kept_groups),
        decisions,
        dropped,
        cv_geometry,
        cv_current,
        unc,
        stats,
    )


def _no(group: str, reason: str) -> dict:
    return {"group": group, "kept": False, "terms": [], "reason": reason}


def _extend(space: parameters.ParameterSpace, x: np.ndarray, to: parameters.ParameterSpace):
    """Deltas of ``space`` re-expressed in ``to`` (zeros for new names)."""
    values = dict(zip(space.free, np.asarray(x, dtype=float), strict=True))
    return np.array([values.get(n, 0.0) for n in to.free])


def _folds(n: int) -> list[np.ndarray]:
    """Held-out index sets: one pose each up to LOO_MAX_POSES, else FOLDS interleaved folds."""
    if n <= LOO_MAX_POSES:
        return [np.array([i]) for i in range(n)]
    return [np.arange(i, n, FOLDS) for i in range(FOLDS)]


def _cv_text(n: int, folds: list) -> str:
    return "leave-one-out" if len(folds) == n else f"{len(folds)}-fold cross-validated"


def _cv(free: list[str], solve, obs, k: float, folds: list[np.ndarray]) -> dict:
    """Cross-validated per-pose errors of the free set ``free``."""
    n = len(obs)
    pos, rot = np.zeros(n), np.full(n, np.nan)
    for held in folds:
        train = obs.subset(np.setdiff1d(np.arange(n), held))
        sp, xf = solve(free, train)
        test = obs.subset(held)
        p, r = measurement.errors(sp, xf, test)
        pos[held] = np.linalg.norm(p, axis=1)
        if r is not None:
            rot[held] = np.linalg.norm(r, axis=1)
    has_rot = obs.has_orientation and k > 0
    score = np.sqrt(pos**2 + (k * rot**2 if has_rot else 0.0))
    return {
        "score_mm": float(np.mean(score)),
        "position_mm": float(np.mean(pos)),
        "orientation_deg": float(np.degrees(np.nanmean(rot))) if obs.has_orientation else None,
    }


def summary_lines(result: JointFit) -> list[str]:
    """What ``identify`` prints about the joint terms."""
    g, f = result.cv_geometry, result.cv_final

    def fig(cv: dict) -> str:
        text = f"position {cv['position_mm']:.4f} mm"
        if cv.get("orientation_deg") is not None:
            text += f", orientation {cv['orientation_deg']:.4f} deg"
        return text

    lines = [
        f"joint terms, cross-validated per-pose error: geometry alone {fig(g)}; "
        f"with the kept terms {fig(f)}"
    ]
    for d in result.decisions:
        verdict = "kept" if d["kept"] else "not kept"
        lines.append(f"  {d['group']:10s} {verdict}: {d['reason']}")
    for d in result.dropped:
        lines.append(f"  not identified: {d['name']:8s} {d['reason']}")
    if result.kept:
        se = result.uncertainty["standard_errors"]
        values = dict(zip(result.space.free, result.x, strict=True))
        shown = [n for n in result.space.free if n in joint_terms.NAMES]
        parts = [f"{n} {values[n]:.3g} +- {se[n]:.2g} {parameters.unit(n)}" for n in shown]
        lines.append("  identified: " + ", ".join(parts))
    return lines


__all__ = ["JointFit", "fit", "payloads", "summary_lines"]


# --- sessions and payloads --------------------------------------------------------


def session_payload(sess: Session, default_kg: float | None = None) -> np.ndarray:
    """Payload of every pose of a session (kg).

    From a ``payload_kg`` column, else the footer's ``payload_kg``, else
    ``default_kg`` (the ``--payload-kg`` option), else 0.
    """
    from calibrator.identify.option_rules import RULES

    # The rule of --payload-kg: a session cannot record what the option refuses.
    rule, n = RULES["payload_kg"], sess.table.num_rows
    if "payload_kg" in sess.table.column_names:
        values = np.array(sess.table["payload_kg"].to_pylist(), dtype=float)
        for extreme in (values.min(), values.max()) if n else ():
            rule.check(float(extreme), "the session's payload_kg column")
    elif "payload_kg" in sess.meta.extra:
        value = rule.check(sess.meta.extra["payload_kg"], "the session's payload_kg")
        values = np.full(n, value)
    else:
        values = np.full(n, 0.0 if default_kg is None else rule.check(default_kg, "--payload-kg"))
    return values


def combine(loaded: list[Session], names: list[str]) -> Session:
    """Several sessions of one arm as one session (poses renumbered in order).

    Raises
    ------
    SessionError
        When the sessions differ in model, nominal table, frame, tool or
        orientation columns: they must be of one arm in one set-up.
    """
    first = loaded[0]
    if len(loaded) == 1:  # one session is itself: no copy, no renumbering
        return first

    import pyarrow as pa

    from calibrator import session
    from calibrator.errors import SessionError

    for other, name in zip(loaded[1:], names[1:], strict=True):
        same = (
            other.meta.model == first.meta.model
            and other.meta.frame == first.meta.frame
            and np.allclose(other.meta.nominal_mdh, first.meta.nominal_mdh)
            and np.allclose(other.meta.flange2tool, first.meta.flange2tool)
            and sorted(other.table.column_names) == sorted(first.table.column_names)
        )
        if not same:
            raise SessionError(
                f"{name}: not the same arm and set-up as {names[0]} (model, nominal table, "
                "frame, tool and columns must match to fit sessions together)"
            )
    columns = first.table.column_names
    table = pa.concat_tables([s.table.select(columns) for s in loaded], promote_options="default")
    n = table.num_rows
    table = table.set_column(columns.index("pose"), "pose", pa.array(np.arange(n)))
    warnings = [w for s in loaded for w in s.warnings]
    return session.Session(table, first.meta, warnings)


def run(
    result: Result,
    sess: Session,
    payload_kg: np.ndarray,
    groups: tuple[str, ...],
    masses: MassModel | None,
    payload_com_mm: np.ndarray,
    noise_mm: float,
) -> tuple[Result, JointFit]:
    """Joint terms on a pipeline result.

    Parameters
    ----------
    result : calibrator.identify.pipeline.Result
        The geometric identification of ``sess``.
    sess : calibrator.session.Session
    payload_kg : ndarray, shape (N,)
        Payload of every pose of the session (kg).
    groups : tuple of str
        Requested groups.
    masses : calibrator.model.mass_models.MassModel or None
        For the gravity torques of compliance.
    payload_com_mm : ndarray, shape (3,)
        Payload centre of mass, flange frame (mm).
    noise_mm : float

    Returns
    -------
    result : calibrator.identify.pipeline.Result
        A new result: free set, deltas, uncertainty, statistics and dropped
        list of the geometry plus the kept terms; the decisions under
        ``details["joint_terms"]``.
    found : JointFit
    """
    o = sess.observations
    torque = None
    if masses is not None:
        torque = joint_terms.gravity_torques(
            sess.meta.nominal_mdh, o.q, masses, payload_kg, payload_com_mm
        )
    obs = measurement.Observations(o.q, o.points, o.rotations, torque)
    found = fit(
        Problem.of(result.space, obs.subset(result.fit_index), result.k),
        result.x,
        obs.subset(result.validation_index),
        groups,
        noise_mm,
        payload_kg[result.fit_index],
    )
    warnings = list(result.warnings)
    if found.kept:
        warnings = _rejudged_warnings(result, found, noise_mm) + implausible_terms(found)
    details = result.details.copy()
    details["joint_terms"] = {
        "requested": list(groups),
        "kept": list(found.kept),
        "decisions": found.decisions,
        "cross_validated_geometry": found.cv_geometry,
        "cross_validated_final": found.cv_final,
        "payloads_kg": payloads(payload_kg).tolist(),
    }
    updated = replace(
        result,
        space=found.space,
        x=found.x,
        uncertainty=found.uncertainty,
        stats=found.stats,
        dropped=list(result.dropped) + found.dropped,
        warnings=warnings,
        details=details,
    )
    return updated, found


def _rejudged_warnings(result, found: JointFit, noise_mm: float) -> list[str]:
    """The pipeline's residual-noise warning, judged again with the kept terms.

    The geometric fit's residuals carry the joint errors the terms now
    explain; its residual-noise and outlier warnings are replaced by the
    noise check on the final fit.
    """
    from calibrator.identify import pipeline

    stale = ("the fit's residual noise", "possible outliers")
    kept = [w for w in result.warnings if not any(s in w for s in stale)]
    sigma = found.uncertainty["residual_sigma"]["position_mm"]
    if sigma > pipeline.NOISE_WARNING * noise_mm:
        kept.append(
            f"the fit's residual noise {sigma:.3g} mm per axis (with the joint terms) is over "
            f"{pipeline.NOISE_WARNING:g} times the {noise_mm:g} mm assumed when choosing the "
            f"free parameters; rerun with --noise-mm {sigma:.2g} to judge them against it"
        )
    return kept


#: A kept term beyond this many times its plausible size gives a warning.
IMPLAUSIBLE = 10.0


def implausible_terms(found: JointFit) -> list[str]:
    """Warnings for kept terms far beyond their plausible size (a unit or model mistake?)."""
    out = []
    for name, value in zip(found.space.free, found.x, strict=True):
        if name not in joint_terms.NAMES:
            continue
        size = joint_terms.PLAUSIBLE[joint_terms.prefix(name)]
        if abs(value) > IMPLAUSIBLE * size:
            out.append(
                f"joint term {name} = {value:.3g} {parameters.unit(name)} is over "
                f"{IMPLAUSIBLE:g} times its plausible {size:g}: check the joint readings "
                "(units, offsets) and the model before trusting it"
            )
    return out
