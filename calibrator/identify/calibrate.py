"""The whole ``identify`` command in Python: sessions in, the calibration.json document out.

:func:`calibrate` loads the sessions, applies a factory nominal file, runs
the identification (:func:`calibrator.identify.pipeline.identify`) and the
joint-term fit, and builds the :class:`~calibrator.calibration.Calibration`
with its provenance, exactly as ``calibrator identify`` does; the command
only parses options and prints. So a script gets the file the command
writes::

    from calibrator.identify.calibrate import calibrate, run
    from calibrator.recorded_options import Options

    done = calibrate(["session.parquet"], Options(seed=1))
    done.calibration.save("calibration.json")
    run(["session.parquet"], "again.json", Options(seed=1))   # checked, written

:func:`recall` is ``identify --like``: the options, model and nominal file a
calibration records, with the ones given explicitly winning.

The provenance's ``created`` time is now, or ``SOURCE_DATE_EPOCH`` (seconds
since 1970, UTC) when that is set, the reproducible-builds convention: two
runs on the same inputs then write the same bytes.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from calibrator import calibration, outputs, robots, session
from calibrator.errors import CalibrationError, IdentifiabilityError
from calibrator.identify import pipeline
from calibrator.recorded_options import PIPELINE, JointTermOptions, Options

if TYPE_CHECKING:
    from calibrator.identify.joint_fit import JointFit

__all__ = ["Calibrated", "Recalled", "calibrate", "created_now", "recall", "run"]


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
    options: Options | None = None,
    *,
    model: str | None = None,
    nominal_file: str | Path | None = None,
    joint: JointTermOptions | None = None,
    on_generation: Callable[[int, float], None] | None = None,
) -> Calibrated:
    """Identify ``session_paths`` into a calibration, as ``calibrator identify`` does.

    Parameters
    ----------
    session_paths : sequence of path
        One session, or several of one arm (e.g. at several payloads).
    options : calibrator.recorded_options.Options, optional
        Default: the command's defaults.
    model : str, optional
        A named model (or description file) instead of the sessions' own table.
    nominal_file : path, optional
        A factory calibration (UR deltas, ROS kinematics YAML) to start from.
    joint : calibrator.recorded_options.JointTermOptions, optional
        Joint terms to fit after the geometry (checked by their rules).
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

    options = options if options is not None else Options()
    joint = joint if joint is not None else JointTermOptions()
    paths = [Path(p) for p in session_paths]
    if not paths:
        raise CalibrationError("no session to identify")
    first = paths[0]
    joint.check()
    groups: tuple[str, ...] = ()
    if joint.joint_term_groups:
        from calibrator.model import joint_terms

        groups = joint_terms.parse_groups(",".join(joint.joint_term_groups))
    payload_com = np.array(joint.payload_com_mm, dtype=float)
    loaded, payloads, notes = _loaded(paths, model, nominal_file, joint.payload_kg, groups)
    started = time.perf_counter()
    try:
        result = pipeline.identify(loaded, options, on_generation=on_generation)
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
        joint=replace(joint, joint_term_groups=groups, payload_com_mm=_xyz(payload_com)),
        versions=calibration.versions(),
        created=created_now(),
    )
    cal = _document(result, found, loaded, paths, provenance, payloads)
    return Calibrated(cal, result, loaded, found, notes, took)


def _loaded(paths, model, nominal_file, payload_kg, groups):
    """The session(s) to identify, the payload of each pose (or None), and notes.

    Several sessions, or joint terms, combine the sessions and read each
    pose's payload (``payload_kg``: of sessions that record none); a
    nominal file replaces the nominal table.
    """
    parts = [session.load(p, model=model) for p in paths]
    loaded, payloads = parts[0], None
    if len(parts) > 1 or groups:
        # Joint terms and several sessions only: a plain identify does not load them.
        from calibrator.identify import joint_fit

        loaded = joint_fit.combine(parts, [str(p) for p in paths])
        payloads = np.concatenate([joint_fit.session_payload(s, payload_kg) for s in parts])
    notes = [f"warning: {doubt}" for doubt in loaded.warnings]
    if nominal_file is not None:
        from calibrator.export import factory_calibration

        meta, line = factory_calibration.apply(loaded.meta, nominal_file)
        loaded = replace(loaded, meta=meta)
        notes.append(line)
    return loaded, payloads, notes


def _document(result, found, loaded, paths, provenance, payloads):
    """The calibration document of an identification (and of its joint-term fit)."""
    cal = calibration.Calibration.from_result(
        result, paths[0], loaded.meta.model, loaded.meta.frame, provenance
    )
    terms = cal.joint_terms
    if found is not None and found.terms.needs_torque:
        assert payloads is not None  # loaded with the joint terms
        joint = provenance.joint
        terms = replace(
            terms,
            payload_kg=float(np.median(payloads)),
            payload_com_mm=np.array(joint.payload_com_mm, dtype=float),
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
    return replace(
        cal,
        joint_terms=terms,
        diagnostics=diagnostics,
        fit=replace(cal.fit, fitted_joint_ranges_rad=ranges),
    )


def _xyz(values: np.ndarray) -> tuple[float, float, float]:
    x, y, z = (float(v) for v in values)
    return x, y, z


def _too_few_hint(path: Path, exc: Exception, n_poses: int, options: Options) -> str:
    """The identification error, naming the file and, if poses are held out, the option."""
    message = f"{path}: {exc}"
    held_out = int(round(options.validation_fraction * n_poses))
    if held_out:
        message += (
            f" ({held_out} of {n_poses} poses held out by "
            f"--validation-fraction {options.validation_fraction:g}; lower it to fit more)"
        )
    return message


def run(
    session_paths: Sequence[str | os.PathLike[str]],
    output: str | os.PathLike[str],
    options: Options | None = None,
    *,
    model: str | None = None,
    nominal_file: str | Path | None = None,
    joint: JointTermOptions | None = None,
    force: bool = False,
    on_generation: Callable[[int, float], None] | None = None,
) -> Calibrated:
    """:func:`calibrate`, then write the calibration to ``output``: ``identify -o OUTPUT``.

    The output is checked before the work (never one of the inputs; an
    existing file only with ``force``) and written whole or not at all.

    Returns
    -------
    Calibrated

    Raises
    ------
    calibrator.errors.CalibrationError
        As :func:`calibrate`, or an output that may not be written.
    """
    inputs = [*session_paths, nominal_file]
    outputs.check(Path(output), inputs=inputs, force=force)
    done = calibrate(
        session_paths, options, model=model, nominal_file=nominal_file, joint=joint,
        on_generation=on_generation,
    )  # fmt: skip
    with outputs.Outputs(inputs=inputs) as batch:
        done.calibration.save(Path(output), batch=batch)
    return done


@dataclass(frozen=True)
class Recalled:
    """What ``identify --like`` re-runs with (:func:`recall`).

    Attributes
    ----------
    options : calibrator.recorded_options.Options
    joint : calibrator.recorded_options.JointTermOptions
    model : str or None
        The recorded named model when it was given with ``--model``, else the one given.
    nominal_file : Path or None
        The recorded factory calibration file, unless one is given.
    notes : list of str
        What to tell the user (``note: ...``, ``warning: ...``).
    """

    options: Options
    joint: JointTermOptions
    model: str | None = None
    nominal_file: Path | None = None
    notes: list[str] = field(default_factory=list)


def recall(
    like: str | os.PathLike[str],
    session_path: str | os.PathLike[str],
    given: Mapping[str, Any] | None = None,
    *,
    model: str | None = None,
    nominal_file: str | Path | None = None,
) -> Recalled:
    """The options of a calibration file, to identify ``session_path`` as it was.

    Each option in ``given`` wins; the others are taken from the file if their
    rule allows (:meth:`calibrator.recorded_options.Options.like`), else
    they keep their defaults. So a script does what ``identify --like`` does.

    Parameters
    ----------
    like : path
        A calibration file.
    session_path : path
        The session to identify (its digest is compared with the recorded one).
    given : mapping, optional
        The options set explicitly, ``{key: value}`` with the keys of
        :data:`calibrator.recorded_options.RULES` (values as the fields hold them).
    model, nominal_file : optional
        Given explicitly (``None``: the recorded one).

    Raises
    ------
    CalibrationError
        A calibration that records no options, a recorded option its rule
        refuses, or a recorded nominal file that is gone or changed.
    """
    given = dict(given or {})
    cal = calibration.load(like)
    recorded = cal.provenance.recorded()
    if not any(key in recorded for key in PIPELINE):
        raise CalibrationError(
            f"--like {like}: the file records no options (written before they were recorded)"
        )
    # What is not given is taken from the file, if its rule allows it.
    where = f"--like {like}"
    options = Options.like(recorded, given, where)
    joint = JointTermOptions.like(recorded, given, where)
    notes = []
    missing = [key for key in PIPELINE if key not in recorded]
    if missing:
        notes.append(
            f"note: {like} does not record {', '.join(missing)}: "
            "those take the values given here (or their defaults)"
        )
    if cal.provenance.session_sha256 not in (None, calibration.digest(Path(session_path))):
        notes.append(
            f"warning: {session_path} is not the session {like} was identified from "
            "(its SHA-256 differs); the options are re-used all the same"
        )
    if model is None and cal.provenance.nominal_source == "model":
        model = cal.model  # it was given with --model; else the session's own table
    return Recalled(options, joint, model, _recorded_nominal(cal, like, nominal_file), notes)


def _recorded_nominal(cal, like, nominal_file):
    """The nominal file given, else the one recorded if it is there unchanged."""
    recorded = cal.provenance.nominal_file
    if nominal_file is not None or recorded is None:
        return None if nominal_file is None else Path(nominal_file)
    path = Path(recorded)
    if not path.is_file():
        raise CalibrationError(
            f"--like {like}: its nominal file {path} is not there; give it with --nominal"
        )
    if calibration.digest(path) != cal.provenance.nominal_sha256:
        raise CalibrationError(
            f"--like {like}: its nominal file {path} has changed since "
            "(SHA-256 differs); give the one it used with --nominal"
        )
    return path
