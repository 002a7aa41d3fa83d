"""The whole ``identify`` command in Python: sessions in, the calibration.json document out.

:func:`calibrate` loads the sessions, applies a factory nominal file, runs
the identification (:func:`calibrator.identify.pipeline.identify`) and the
joint-term fit, and builds the :class:`~calibrator.calibration.Calibration`
with its provenance, exactly as ``calibrator identify`` does; the command
only parses options and prints. So a script gets the file the command
writes::

    from calibrator.identify.calibrate import calibrate
    from calibrator.identify.pipeline import Options

    done = calibrate(["session.parquet"], Options(seed=1))
    done.calibration.save("calibration.json")

The provenance's ``created`` time is now, or ``SOURCE_DATE_EPOCH`` (seconds
since 1970, UTC) when that is set, the reproducible-builds convention: two
runs on the same inputs then write the same bytes.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from calibrator import calibration, robots, session
from calibrator.errors import CalibrationError, IdentifiabilityError
from calibrator.identify import pipeline

if TYPE_CHECKING:
    from calibrator.identify.joint_fit import JointFit

__all__ = ["Calibrated", "JointOptions", "calibrate", "created_now"]


@dataclass(frozen=True)
class JointOptions:
    """The joint-term options as given (``None``: not given), for ``--like`` to fill in.

    Named as recorded (:data:`calibrator.recorded_options.JOINT`).

    Attributes
    ----------
    joint_term_groups : str, optional
        ``scale``, ``harmonic``, ``compliance`` or several, comma-separated.
    mass_model : str, optional
        A model name or a mass-model file (compliance terms).
    payload_kg : float, optional
        The payload during the session(s), kg.
    payload_com_mm : str
        Its centre of mass on the flange, ``X,Y,Z`` in mm.
    """

    joint_term_groups: str | None = None
    mass_model: str | None = None
    payload_kg: float | None = None
    payload_com_mm: str = "0,0,0"


@dataclass(frozen=True)
class Calibrated:
    """What :func:`calibrate` made.

    Attributes
    ----------
    calibration : calibrator.calibration.Calibration
        The document ``identify`` writes (``.save(path)``).
    result : calibrator.identify.pipeline.Result
        The identification (statistics, uncertainty, dropped parameters, warnings).
    session : calibrator.session.Session
        The session identified (several combined into one).
    joint : calibrator.identify.joint_fit.JointFit, optional
        The joint-term fit (:func:`calibrator.identify.joint_fit.run`), when terms were asked.
    notes : list of str
        What the loading said: doubts about the session, the nominal file applied.
    took_s : float
        Identification time, s.
    """

    calibration: calibration.Calibration
    result: pipeline.Result
    session: session.Session
    joint: JointFit | None = None
    notes: list[str] = field(default_factory=list)
    took_s: float = 0.0


def created_now() -> str:
    """The provenance time: ``SOURCE_DATE_EPOCH`` when set, else now (UTC, ISO 8601)."""
    epoch = os.environ.get("SOURCE_DATE_EPOCH")
    if epoch is not None and epoch.strip().isdigit():
        when = datetime.fromtimestamp(int(epoch), UTC)
    else:
        when = datetime.now(UTC)
    return when.isoformat(timespec="seconds")


def calibrate(
    session_paths: Sequence[str | os.PathLike[str]],
    options: pipeline.Options | None = None,
    *,
    model: str | None = None,
    nominal_file: str | Path | None = None,
    joint: JointOptions | None = None,
    on_generation: Callable[[int, float], None] | None = None,
) -> Calibrated:
    """Identify ``session_paths`` into a calibration, as ``calibrator identify`` does.

    Parameters
    ----------
    session_paths : sequence of path
        One session, or several of one arm (e.g. at several payloads).
    options : calibrator.identify.pipeline.Options, optional
        Default: the command's defaults.
    model : str, optional
        A named model (or description file) instead of the sessions' own table.
    nominal_file : path, optional
        A factory calibration (UR deltas, ROS kinematics YAML) to start from.
    joint : JointOptions, optional
        Joint terms to fit after the geometry.
    on_generation : callable, optional
        ``on_generation(generation, best_cost)`` during the swarm (progress).

    Returns
    -------
    Calibrated

    Raises
    ------
    calibrator.errors.CalibrationError
        A session, option or nominal file refused, or too few poses for the
        free parameters (naming the file and the held-out share).
    """
    import time

    options = options if options is not None else pipeline.Options()
    joint = joint if joint is not None else JointOptions()
    paths = [Path(p) for p in session_paths]
    if not paths:
        raise CalibrationError("no session to identify")
    first = paths[0]
    groups: tuple[str, ...] = ()
    if joint.joint_term_groups is not None:
        from calibrator.model import joint_terms

        groups = tuple(joint_terms.parse_groups(joint.joint_term_groups))
    payload_com = _three(joint.payload_com_mm, "--payload-com-mm")
    parts = [session.load(p, model=model) for p in paths]
    loaded = parts[0]
    payloads = None
    if len(parts) > 1 or groups:
        # Joint terms and several sessions only: a plain identify does not load them.
        from calibrator.identify import joint_fit

        loaded = joint_fit.combine(parts, [str(p) for p in paths])
        payloads = np.concatenate([joint_fit.session_payload(s, joint.payload_kg) for s in parts])
    notes = [f"warning: {doubt}" for doubt in loaded.warnings]
    if nominal_file is not None:
        from calibrator.export import factory_calibration

        meta, line = factory_calibration.apply(loaded.meta, nominal_file)
        loaded = replace(loaded, meta=meta)
        notes.append(line)
    started = time.perf_counter()
    shown = options if on_generation is None else replace(options, on_generation=on_generation)
    try:
        result = pipeline.identify(loaded, shown)
    except IdentifiabilityError as exc:
        raise CalibrationError(_too_few_hint(first, exc, len(loaded.table), options)) from None
    found = None
    if groups:
        from calibrator.identify import joint_fit
        from calibrator.robots import masses as arm_masses

        source = joint.mass_model or loaded.meta.model
        masses = None
        if "compliance" in groups and source:
            masses = arm_masses.resolve(source)
        assert payloads is not None  # loaded with the joint terms above
        result, found = joint_fit.run(
            result, loaded, payloads, groups, masses, payload_com, options.noise_mm
        )
    took = time.perf_counter() - started
    provenance = calibration.Provenance(
        session_sha256=calibration.digest(first),
        nominal_source="file" if nominal_file else "model" if model else "session",
        nominal_file=None if nominal_file is None else str(nominal_file),
        nominal_sha256=None if nominal_file is None else calibration.digest(nominal_file),
        joint_term_groups=",".join(groups),
        mass_model=joint.mass_model,
        payload_kg=joint.payload_kg,
        payload_com_mm=[float(v) for v in payload_com],
        versions=calibration.versions(),
        created=created_now(),
    )
    cal = calibration.Calibration.from_result(
        result, first, loaded.meta.model, loaded.meta.frame, provenance
    )
    terms = cal.joint_terms
    if found is not None and found.terms.needs_torque:
        assert payloads is not None  # loaded with the joint terms
        terms = replace(
            terms,
            payload_kg=float(np.median(payloads)),
            payload_com_mm=payload_com,
            mass_model=str(joint.mass_model or loaded.meta.model),
        )
    diagnostics = dict(cal.diagnostics)
    if len(paths) > 1:
        diagnostics["sessions"] = [str(p) for p in paths]
    # compensate warns about targets outside the joint ranges the fit saw: the
    # controller's angles, as every joint value a user reads.
    convention = robots.convention_of(loaded.meta.model)
    fitted_q = convention.to_controller(loaded.observations.q[result.fit_index])
    ranges = np.column_stack([fitted_q.min(axis=0), fitted_q.max(axis=0)]).tolist()
    cal = replace(
        cal,
        joint_terms=terms,
        diagnostics=diagnostics,
        fit=replace(cal.fit, fitted_joint_ranges_rad=ranges),
    )
    return Calibrated(cal, result, loaded, found, notes, took)


def _three(text: str, what: str) -> np.ndarray:
    """``'x,y,z'`` -> ndarray (3,) of finite numbers (the strict grammar)."""
    from calibrator.inputs import grammar

    parts = str(text).split(",")
    if len(parts) != 3:
        raise CalibrationError(f"{what} needs three numbers x,y,z, got {text!r}")
    return np.array([grammar.parse_number(p, what) for p in parts])


def _too_few_hint(path: Path, exc: Exception, n_poses: int, options: pipeline.Options) -> str:
    """The identification error, naming the file and, if poses are held out, the option."""
    message = f"{path}: {exc}"
    held_out = int(round(options.validation_fraction * n_poses))
    if held_out:
        message += (
            f" ({held_out} of {n_poses} poses held out by "
            f"--validation-fraction {options.validation_fraction:g}; lower it to fit more)"
        )
    return message
