"""The identified arm: :class:`Calibration`, what ``identify`` writes and exporters read.

The file layout (``calibration.json``) is documented key by key in
``docs/calibration-format.md``. In short, a JSON object with

- typed keys read into the fields of :class:`Calibration`: ``format``,
  ``version``, ``model``, ``frame``, ``session``, ``nominal_mdh``, ``mdh``,
  ``base2tracker``, ``flange2tool``, ``base0``, ``tool0``,
  ``free_parameters``, ``deltas``, ``dropped_parameters``;
- ``parameters``: one record per candidate parameter with its nominal and
  identified value and whether it was free (derived; rewritten on save);
- the provenance keys of :class:`Provenance` (``session_sha256``,
  ``method``, ``loss``, ``seed``, ``validation_fraction``, ``k``,
  ``noise_mm``, ``tool_known``, ...): every option that changes the result,
  so ``identify --like`` can re-run it;
- the fit report keys of :class:`FitReport` (``stats``, ``uncertainty``,
  ``warnings``, ``outliers``, ``validation_poses``, ``solver``);
- every other key (what later versions of ``identify`` add) kept as it is
  in :attr:`Calibration.diagnostics`.

All keys sit at the top level of the document (the layout of version 1, so
older files read unchanged); each typed part reads and writes its own keys
explicitly. Reading happens in one place, :func:`from_json` (through
:func:`load`), where consistency checks of a document belong.

The file is strict JSON: a NaN or infinity anywhere refuses the save, and
:func:`load` checks types, shapes, finiteness, rigidity of the frames and
consistency of the fixed parameters before anything uses the file.
"""

from __future__ import annotations

import hashlib
import json
import math
import platform
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from calibrator import outputs, recorded_options
from calibrator.errors import CalibrationError
from calibrator.fit_records import FitStats, SolverDetails, Uncertainty
from calibrator.inputs import jsonfile, messages
from calibrator.inputs.json_fields import Fields
from calibrator.model import consistency, frames, kinematics, parameters, plausibility, rotations
from calibrator.model.joint_terms import JointTerms
from calibrator.model.plausibility import PLAUSIBLE_DELTA
from calibrator.recorded_options import JointTermOptions, Options

FORMAT = "calibrator.calibration"
VERSION = 1
FRAMES = ("base", "tracker")
#: Where a calibration's nominal table came from (:attr:`Provenance.nominal_source`).
NOMINAL_SOURCES = ("session", "model", "file")
_FIELDS = kinematics.FIELDS
#: Refuse files larger than this: a calibration is a few kB.
MAX_BYTES = 16 * 2**20
#: A fixed parameter may differ from its nominal value by this much (rounding).
_FIXED_TOL = 1e-9


@dataclass(frozen=True)
class Provenance:
    """Where a calibration came from: its session and every option that changes it.

    Attributes
    ----------
    session_sha256 : str or None
        SHA-256 of the session file's bytes (hex).
    nominal_source : {'session', 'model', 'file'} or None
        Where the nominal table came from: the session's footer, a named
        model given with ``--model``, or a factory calibration file.
    nominal_file, nominal_sha256 : str or None
        The factory calibration given with ``--nominal`` and its digest;
        ``None`` when the nominal table came from the session or the model.
    options : calibrator.recorded_options.Options or None
        The pipeline options identify ran with, ``k`` and ``tool_known``
        resolved (the weight used, 0 without orientation data; whether the
        tool frame was fixed). ``None``: the file records none.
    joint : calibrator.recorded_options.JointTermOptions or None
        The joint-term options (``identify --joint-terms`` and its
        companions); ``None``: the file records none.
    unrecorded : frozenset of str
        Option keys of :data:`calibrator.recorded_options.RULES` a file that
        records some options lacks (written before those were recorded):
        their fields in ``options`` and ``joint`` hold the defaults, and are
        not written back.
    versions : dict
        ``{"calibrator", "numpy", "scipy", "python"}`` version strings.
    created : str or None
        UTC time the calibration was made (ISO 8601).

    ``None`` means "not recorded" (a file written before this was recorded).
    In calibration.json every option is a key of the top level, named as
    its field (the layout of version 1).
    """

    session_sha256: str | None = None
    nominal_source: str | None = None
    nominal_file: str | None = None
    nominal_sha256: str | None = None
    options: Options | None = None
    joint: JointTermOptions | None = None
    unrecorded: frozenset[str] = frozenset()
    versions: dict[str, str] = field(default_factory=dict)
    created: str | None = None

    #: JSON type of each key, in file order; the options' come from their rules.
    _TYPES = {
        "session_sha256": str,
        "nominal_source": str,
        "nominal_file": str,
        "nominal_sha256": str,
        **{
            key: list if rule.kind is tuple else rule.kind
            for key, rule in recorded_options.RULES.items()
        },
        "versions": dict,
        "created": str,
    }
    #: Keys of calibration.json this part reads and writes.
    KEYS = tuple(_TYPES)

    def recorded(self) -> dict[str, Any]:
        """The recorded options, pipeline and joint terms: ``{key: value}`` as in the file.

        ``None`` and what the file does not record are left out.
        """
        out: dict[str, Any] = {}
        for record in (self.options, self.joint):
            if record is not None:
                out.update(record.recorded())
        return {k: v for k, v in out.items() if k not in self.unrecorded}

    def to_json(self) -> dict[str, Any]:
        """The provenance keys of calibration.json; ``None`` values are left out."""
        values = {
            "session_sha256": self.session_sha256,
            "nominal_source": self.nominal_source,
            "nominal_file": self.nominal_file,
            "nominal_sha256": self.nominal_sha256,
            **self.recorded(),
            "versions": dict(self.versions) or None,
            "created": self.created,
        }
        return {k: v for k, v in values.items() if v is not None}

    @classmethod
    def from_json(cls, doc: dict[str, Any], where: str | Path = "calibration") -> Provenance:
        """The provenance keys of a parsed document; missing keys read as not recorded.

        Raises
        ------
        CalibrationError
            A key present with the wrong JSON type.
        """
        values: dict[str, Any] = {}
        for key, kind in cls._TYPES.items():
            value = doc.get(key)
            if value is None:
                continue
            ok = isinstance(value, kind) and not (kind is int and isinstance(value, bool))
            if kind is float:
                ok = isinstance(value, int | float) and not isinstance(value, bool)
                value = float(value) if ok else value
            if not ok:
                raise CalibrationError(
                    f"{where}: '{key}' must be a JSON {_JSON_TYPE[kind]}, got {value!r:.40}"
                )
            values[key] = value
        source = values.get("nominal_source")
        if source is not None and source not in NOMINAL_SOURCES:
            raise CalibrationError(
                f"{where}: 'nominal_source' must be one of {', '.join(NOMINAL_SOURCES)}, "
                f"got {messages.shown(source)}"
            )
        com = values.get("payload_com_mm")
        if com is not None:
            if len(com) != 3 or not all(_is_number(v) for v in com):
                raise CalibrationError(
                    f"{where}: 'payload_com_mm' must be three numbers x, y, z (mm)"
                )
            values["payload_com_mm"] = [float(v) for v in com]
        records: dict[str, Any] = {}
        unrecorded: set[str] = set()
        for name, kind in (("options", Options), ("joint", JointTermOptions)):
            given = {k: values.pop(k) for k in kind.rules() if k in values}
            records[name] = kind.from_record(given) if given else None
            if given:
                # A default of None is never written: only the others can be missing.
                unset = kind.from_record({}).recorded()
                unrecorded.update(k for k in unset if k not in given)
        return cls(**values, **records, unrecorded=frozenset(unrecorded))


def _is_number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and np.isfinite(value)


_JSON_TYPE = {
    str: "string",
    int: "integer",
    float: "number",
    bool: "boolean",
    dict: "object",
    list: "array",
}


@dataclass(frozen=True)
class FitReport:
    """How the fit went: statistics, uncertainty, warnings, outliers, solver.

    Attributes
    ----------
    stats : calibrator.fit_records.FitStats
        ``{"fit"|"validation": {"before"|"after": error statistics}}``, see
        :func:`calibrator.identify.accuracy.error_stats` (mm, deg).
    uncertainty : calibrator.fit_records.Uncertainty
        :func:`calibrator.identify.uncertainty.analyse` (standard errors in
        the units of ``deltas``, residual sigma, predicted held-out error,
        correlations).
    warnings : list of str
        Sentences about the session and the fit.
    outliers : list of int
        Pose numbers a robust loss set aside (with ``lsq``: flagged).
    validation_poses : list of int
        Row indices (0-based, session order) of the held-out poses.
    solver : calibrator.fit_records.SolverDetails
        What each fitter reported (cost, evaluations, message), and the
        swarm's ``convergence`` as ``[[generation, best cost], ...]``.
    fitted_joint_ranges_rad : list
        ``[[min, max]] * 6`` joint angles of the fitted poses (rad): beyond
        them the model is extrapolated (``compensate`` warns); empty when
        not recorded.
    """

    stats: FitStats = field(default_factory=lambda: FitStats())
    uncertainty: Uncertainty = field(default_factory=lambda: Uncertainty())
    warnings: list[str] = field(default_factory=list)
    outliers: list[int] = field(default_factory=list)
    validation_poses: list[int] = field(default_factory=list)
    solver: SolverDetails = field(default_factory=lambda: SolverDetails())
    fitted_joint_ranges_rad: list[list[float]] = field(default_factory=list)

    #: Keys of calibration.json this part reads and writes.
    KEYS = (
        "stats",
        "uncertainty",
        "warnings",
        "outliers",
        "validation_poses",
        "solver",
        "fitted_joint_ranges_rad",
    )

    def to_json(self) -> dict[str, Any]:
        """The fit report keys of calibration.json (JSON values)."""
        return _jsonable({key: getattr(self, key) for key in self.KEYS})

    @classmethod
    def from_json(cls, doc: dict[str, Any], where: str | Path = "calibration") -> FitReport:
        """The fit report keys of a parsed document; missing ones read as empty.

        Also reads ``outlier_poses`` (a name some readers used for ``outliers``).

        Raises
        ------
        CalibrationError
            A key present with the wrong JSON type.
        """
        values: dict[str, Any] = {}
        outliers = doc.get("outliers", doc.get("outlier_poses"))
        for key, kind in (
            ("stats", dict),
            ("uncertainty", dict),
            ("solver", dict),
            ("warnings", list),
            ("outliers", list),
            ("validation_poses", list),
            ("fitted_joint_ranges_rad", list),
        ):
            value = outliers if key == "outliers" else doc.get(key)
            if value is None:
                continue
            if not isinstance(value, kind):
                raise CalibrationError(
                    f"{where}: '{key}' must be a JSON {'object' if kind is dict else 'list'}"
                )
            values[key] = value
        for key in ("outliers", "validation_poses"):
            if not all(type(i) is int for i in values.get(key, [])):
                raise CalibrationError(f"{where}: '{key}' must be a list of pose numbers")
        ranges = values.get("fitted_joint_ranges_rad", [])
        if ranges and not (
            len(ranges) == 6
            and all(
                isinstance(r, list) and len(r) == 2 and all(_is_number(v) for v in r)
                for r in ranges
            )
        ):
            raise CalibrationError(
                f"{where}: 'fitted_joint_ranges_rad' must be six [min, max] pairs (rad)"
            )
        values["warnings"] = [str(w) for w in values.get("warnings", [])]
        return cls(**values)


def digest(path: str | Path) -> str:
    """SHA-256 of a file's bytes (hex), for :attr:`Provenance.session_sha256`."""
    sha = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            sha.update(block)
    return sha.hexdigest()


def versions() -> dict[str, str]:
    """Versions of what computes a calibration: this program, numpy, scipy, Python."""
    from importlib.metadata import version

    from calibrator import __version__

    return {
        "calibrator": __version__,
        "numpy": np.__version__,
        "scipy": version("scipy"),
        "python": platform.python_version(),
    }


#: Keys with a typed field in :class:`Calibration`; others go to ``diagnostics``.
TYPED_KEYS = (
    "format",
    "version",
    "model",
    "frame",
    "session",
    "nominal_mdh",
    "mdh",
    "base2tracker",
    "flange2tool",
    "base0",
    "tool0",
    "free_parameters",
    "deltas",
    "dropped_parameters",
    "parameters",
    "outlier_poses",
    *FitReport.KEYS,
    *Provenance.KEYS,
    "joint_terms",
)


@dataclass(frozen=True)
class Calibration:
    """A calibrated arm: nominal and identified model, frames and what was free.

    Attributes
    ----------
    nominal_mdh : ndarray, shape (6, 5)
        MDH table the deltas were added to (mm, rad).
    mdh : ndarray, shape (6, 5)
        Identified MDH table (mm, rad).
    base2tracker : ndarray, shape (4, 4)
        Robot base frame in the tracker frame (mm); the identity for a
        session measured in the base frame.
    flange2tool : ndarray, shape (4, 4)
        Tool frame in the flange frame (mm); only its translation is identified.
    free : tuple of str
        Identified parameters (names of :data:`calibrator.model.parameters.ALL_NAMES`).
    deltas : dict
        Solver value of each free parameter (mm or rad, see ``docs/conventions.md``).
    dropped : list of dict
        ``{"name", "reason"}`` of each candidate left out.
    model : str or None
        Name of the nominal model, if it was a named one.
    frame : {'base', 'tracker'}
        Frame of the session's points.
    base0, tool0 : ndarray, shape (4, 4)
        First guesses of ``base2tracker`` and ``flange2tool`` (the frames'
        "nominal" values).
    session : str or None
        Path of the session it came from.
    provenance : Provenance
        Session digest and every option that changes the result.
    fit : FitReport
        Statistics, uncertainty, warnings, outliers, solver.
    diagnostics : dict
        Every other key of the file (what later versions add), JSON values.
    joint_terms : JointTerms
        Joint error terms (:mod:`calibrator.model.joint_terms`), zero when not used;
        written under ``"joint_terms"`` only when some term is nonzero.
    """

    nominal_mdh: np.ndarray
    mdh: np.ndarray
    base2tracker: np.ndarray = field(default_factory=lambda: np.eye(4))
    flange2tool: np.ndarray = field(default_factory=lambda: np.eye(4))
    free: tuple[str, ...] = ()
    deltas: dict[str, float] = field(default_factory=dict)
    dropped: list[dict[str, str]] = field(default_factory=list)
    model: str | None = None
    frame: str = "base"
    base0: np.ndarray = field(default_factory=lambda: np.eye(4))
    tool0: np.ndarray = field(default_factory=lambda: np.eye(4))
    session: str | None = None
    provenance: Provenance = field(default_factory=Provenance)
    fit: FitReport = field(default_factory=FitReport)
    diagnostics: dict[str, object] = field(default_factory=dict)
    joint_terms: JointTerms = field(default_factory=JointTerms.zero)

    def __post_init__(self) -> None:
        # Frozen, arrays included: checked read-only copies go in once, here;
        # derive a changed calibration with dataclasses.replace().
        tables = {
            name: kinematics.check_mdh(getattr(self, name)) for name in ("nominal_mdh", "mdh")
        }
        for name in ("base2tracker", "flange2tool", "base0", "tool0"):
            tables[name] = frames.check_transform(getattr(self, name), name)
        for name, table in tables.items():
            table = table.copy()
            table.setflags(write=False)
            object.__setattr__(self, name, table)
        object.__setattr__(self, "free", tuple(self.free))

    @classmethod
    def from_result(
        cls,
        # calibrator.identify.pipeline.Result: identify sits above the documents it writes.
        result: Any,
        session_path: str | Path | None = None,
        model: str | None = None,
        frame: str = "base",
        provenance: Provenance | None = None,
    ) -> Calibration:
        """The calibration of an identification result.

        Parameters
        ----------
        result : calibrator.identify.pipeline.Result
        session_path : str or Path, optional
        model : str, optional
        frame : {'base', 'tracker'}
        provenance : Provenance, optional
            What the caller knows beyond the result (session digest, nominal
            file, versions, time); the options are filled in from ``result``.
        """
        space = result.space
        mdh, base2tracker, flange2tool = space.unpack(result.x)
        x = np.asarray(result.x, dtype=float)
        # Joint terms go under "joint_terms"; free/deltas stay geometric.
        terms = JointTerms.from_vector(space.joint_terms(x))
        geometric = [i for i, n in enumerate(space.free) if n in parameters.ALL_NAMES]
        recorded = provenance or Provenance()
        # The options as run, with the weight used and whether the tool was fixed.
        options = replace(result.options, k=result.k, tool_known=result.tool_known)
        provenance = replace(recorded, options=options.normalised(), unrecorded=frozenset())
        fit = FitReport(
            stats=_jsonable(result.stats),
            uncertainty=_jsonable(result.uncertainty),
            warnings=[str(w) for w in result.warnings],
            outliers=[int(p) for p in result.outliers],
            validation_poses=[int(i) for i in result.validation_index],
            solver=_jsonable(result.details),
        )
        return cls(
            nominal_mdh=space.nominal_mdh,
            mdh=mdh,
            base2tracker=base2tracker,
            flange2tool=flange2tool,
            free=tuple(space.free[i] for i in geometric),
            deltas={space.free[i]: float(x[i]) for i in geometric},
            dropped=[dict(d) for d in result.dropped],
            model=model,
            frame=frame,
            base0=space.base0,
            tool0=space.tool0,
            session=None if session_path is None else str(session_path),
            provenance=provenance,
            fit=fit,
            joint_terms=terms,
        )

    def parameter_records(self) -> list[dict[str, Any]]:
        """One record per candidate parameter: nominal, identified, free or fixed.

        MDH entries hold the table values; ``base_*`` the translation (mm)
        and ``Rx Ry Rz`` angles (rad, :func:`calibrator.model.rotations.angles_xyz`)
        of ``base2tracker`` (nominal: of ``base0``); ``tool_x/y/z`` the tool
        point in the flange frame and ``tool_rx/ry/rz`` the angles of its
        rotation (nominal: of ``tool0``).

        ``delta`` is :func:`calibrator.model.parameters.all_deltas`: for the base
        frame the move in the nominal base frame (as the solver, the report
        and the CSV export give it), not ``identified - nominal``.

        Returns
        -------
        list of dict
            ``{"name", "unit", "nominal", "identified", "delta", "free"}``.
        """
        nominal = _flat_values(self.nominal_mdh, self.base0, self.tool0)
        identified = _flat_values(self.mdh, self.base2tracker, self.flange2tool)
        delta = self.all_deltas()
        free = set(self.free)
        return [
            {
                "name": name,
                "unit": parameters.unit(name),
                "nominal": float(nominal[i]),
                "identified": float(identified[i]),
                "delta": delta[name],
                "free": name in free,
            }
            for i, name in enumerate(parameters.ALL_NAMES)
        ]

    def all_deltas(self) -> dict[str, float]:
        """The delta of every named parameter (:func:`calibrator.model.parameters.all_deltas`).

        Free parameters give their recorded solver value (:attr:`deltas`), so
        every reader shows the same number to the last bit; the others are
        computed from the frames and tables (zero up to rounding).

        Returns
        -------
        dict
            ``{name: delta}`` in :data:`calibrator.model.parameters.ALL_NAMES` order (mm, rad).
        """
        values = parameters.all_deltas(
            self.nominal_mdh, self.base0, self.tool0, self.mdh, self.base2tracker, self.flange2tool
        )
        out = dict(zip(parameters.ALL_NAMES, map(float, values), strict=True))
        out.update({k: float(v) for k, v in self.deltas.items() if k in out})
        return out

    def to_json(self) -> dict[str, Any]:
        """The calibration.json document (plain JSON values)."""
        doc = dict(self.diagnostics)
        doc.update(self.fit.to_json())
        doc.update(self.provenance.to_json())
        doc.update(
            format=FORMAT,
            version=VERSION,
            model=self.model,
            frame=self.frame,
            session=self.session,
            nominal_mdh=self.nominal_mdh.tolist(),
            mdh=mdh_records(self.mdh),
            base2tracker=self.base2tracker.tolist(),
            flange2tool=self.flange2tool.tolist(),
            base0=self.base0.tolist(),
            tool0=self.tool0.tolist(),
            free_parameters=list(self.free),
            deltas={k: float(v) for k, v in self.deltas.items()},
            dropped_parameters=self.dropped,
            parameters=self.parameter_records(),
        )
        if self.joint_terms.used:
            doc["joint_terms"] = self.joint_terms.to_json()
        return _jsonable(doc)

    def save(self, path: outputs.PathLike, batch: outputs.Outputs | None = None) -> None:
        """Write strict JSON atomically; refuses NaN or infinity anywhere.

        With ``batch`` (an :class:`calibrator.outputs.Outputs`), as part of it.

        Raises
        ------
        CalibrationError
            Naming the first key that holds a non-finite number; nothing is written.
        """
        doc = self.to_json()
        found = jsonfile.first_leaf(
            doc, lambda leaf: isinstance(leaf, float) and not math.isfinite(leaf)
        )
        bad = None if found is None else (found[0] or "value")
        if bad is not None:
            raise CalibrationError(
                f"refusing to write {path}: {bad} is not a finite number "
                "(calibration files are strict JSON)"
            )
        write(path, doc, batch=batch)

    @classmethod
    def load(cls, path: outputs.PathLike) -> Calibration:
        """Read and check a calibration file; see :func:`load`."""
        return load(path)


def mdh_records(mdh: ArrayLike) -> list[dict[str, float]]:
    """MDH table (6, 5) as a list of six ``{"a_mm": ..., ...}`` dicts."""
    return [dict(zip(_FIELDS, map(float, row), strict=True)) for row in np.asarray(mdh)]


def mdh_from_records(records: Iterable[Mapping[str, Any]]) -> np.ndarray:
    """Inverse of :func:`mdh_records`; returns an ndarray (6, 5)."""
    return np.array([[float(r[f]) for f in _FIELDS] for r in records])


def write(path: outputs.PathLike, document: object, batch: outputs.Outputs | None = None) -> None:
    """Write a JSON document atomically (strict JSON: ValueError on NaN/inf).

    With ``batch`` (an :class:`calibrator.outputs.Outputs`), as part of it.
    """
    text = json.dumps(document, indent=2, allow_nan=False) + "\n"
    if batch is None:
        outputs.write_text(path, text)
    else:
        batch.text(path, text)


def load(path: outputs.PathLike) -> Calibration:
    """Read and validate a calibration.json.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    Calibration

    Raises
    ------
    CalibrationError
        One line naming what is wrong: not JSON or not strict JSON (NaN,
        Infinity), wrong format or version, a key with the wrong type or
        shape, a non-finite number, a frame that is not rigid, a fixed
        parameter that differs from its nominal value, or an identified value
        implausibly far from nominal.
    """
    path = Path(path)
    if not path.is_file():
        raise CalibrationError(f"calibration file not found: {path}")
    if path.stat().st_size > MAX_BYTES:
        raise CalibrationError(
            f"{path}: {path.stat().st_size} bytes is too large for a calibration"
        )
    doc = jsonfile.load_json(path.read_bytes(), str(path))
    return from_json(doc, path)


def from_json(doc: object, where: str | Path = "calibration") -> Calibration:
    """A :class:`Calibration` from a parsed document, validated like :func:`load`."""
    check = Fields(where)
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise CalibrationError(f"{where} is not a calibrator calibration file")
    version = doc.get("version")
    if type(version) is not int or version != VERSION:
        raise CalibrationError(
            f"{where}: calibration version {messages.shown(version)} is not supported "
            f"(this program reads version {VERSION})"
        )
    nominal = check.table(doc, "nominal_mdh", (6, 5))
    records = doc.get("mdh")
    if not isinstance(records, list) or len(records) != 6:
        raise CalibrationError(f"{where}: 'mdh' must be a list of six joints")
    for j, rec in enumerate(records):
        if not isinstance(rec, dict) or set(rec) != set(_FIELDS):
            raise CalibrationError(
                f"{where}: 'mdh' joint {j + 1} must have exactly the keys {', '.join(_FIELDS)}"
            )
    mdh = check.table({"mdh": [[r[f] for f in _FIELDS] for r in records]}, "mdh", (6, 5))
    transforms = {}
    for key in ("base2tracker", "flange2tool", "base0", "tool0"):
        if key in ("base0", "tool0") and key not in doc:
            continue
        arr = check.table(doc, key, (4, 4))
        try:
            transforms[key] = frames.check_transform(arr, key)
        except ValueError as exc:
            raise CalibrationError(f"{where}: {exc}") from None
    # The bounds a session's frames meet: every export derives from these.
    plausibility.check_frames(transforms, str(where))
    free = doc.get("free_parameters")
    if not isinstance(free, list) or not all(isinstance(n, str) for n in free):
        raise CalibrationError(f"{where}: 'free_parameters' must be a list of names")
    unknown = [n for n in free if n not in parameters.ALL_NAMES]
    if unknown:
        raise CalibrationError(
            f"{where}: 'free_parameters' has unknown names {messages.shown(unknown, 60)}"
        )
    repeated = sorted({n for n in free if free.count(n) > 1})
    if repeated:
        raise CalibrationError(f"{where}: 'free_parameters' repeats {', '.join(repeated)}")
    deltas = doc.get("deltas", {})
    if not isinstance(deltas, dict) or set(deltas) != set(free):
        raise CalibrationError(f"{where}: 'deltas' must map each free parameter to its value")
    for name, value in deltas.items():
        check.number(value, f"deltas.{name}")
    dropped = doc.get("dropped_parameters", [])
    if not isinstance(dropped, list) or not all(
        isinstance(d, dict) and isinstance(d.get("name"), str) and isinstance(d.get("reason"), str)
        for d in dropped
    ):
        raise CalibrationError(f"{where}: 'dropped_parameters' must be a list of {{name, reason}}")
    for key in ("model", "session"):
        if doc.get(key) is not None and not isinstance(doc[key], str):
            raise CalibrationError(f"{where}: '{key}' must be a string or null")
    frame = doc.get("frame", "base")
    if frame not in FRAMES:
        raise CalibrationError(
            f"{where}: 'frame' must be 'base' or 'tracker', got {messages.shown(frame)}"
        )
    _check_fixed(mdh, nominal, free, where)
    diagnostics = {k: v for k, v in doc.items() if k not in TYPED_KEYS}
    try:
        terms = JointTerms.from_json(doc.get("joint_terms"))
    except CalibrationError as exc:
        raise CalibrationError(f"{where}: {exc}") from None
    calibration = Calibration(
        provenance=Provenance.from_json(doc, where),
        fit=FitReport.from_json(doc, where),
        nominal_mdh=nominal,
        mdh=mdh,
        free=tuple(free),
        deltas={k: float(v) for k, v in deltas.items()},
        dropped=dropped,
        model=_model_name(doc.get("model")),
        frame=frame,
        session=doc.get("session"),
        diagnostics=diagnostics,
        joint_terms=terms,
        **transforms,
    )
    consistency.check_calibration(calibration, str(where), _catalogue_mdh(calibration.model))
    return calibration


def _model_name(name: str | None) -> str | None:
    """A named model as the catalogue spells it (``"UR10E"`` is ``"ur10e"``); others as written.

    Model names compare case-insensitively everywhere (``--model UR10e``), so
    a hand-written file's spelling must not make it "another arm".
    """
    from calibrator import robots

    key = name.strip().lower() if name is not None else None
    return key if key in robots.names() else name


def _catalogue_mdh(name: str | None) -> np.ndarray | None:
    """The catalogue's MDH table of a named model (mm, rad); None for other names."""
    from calibrator import robots

    if name is None or name.strip().lower() not in robots.names():
        return None
    return robots.get(name).mdh


def _check_fixed(mdh, nominal, free, where):
    """Fixed MDH entries equal their nominal values; free ones stay plausible."""
    delta = (mdh - nominal).ravel()
    free = set(free)
    for i, name in enumerate(parameters.MDH_NAMES):
        unit = parameters.unit(name)
        if name not in free and abs(delta[i]) > _FIXED_TOL:
            raise CalibrationError(
                f"{where}: {name} is not a free parameter but differs from its nominal "
                f"value by {delta[i]:.6g} {unit}"
            )
        if abs(delta[i]) > PLAUSIBLE_DELTA[unit]:
            raise CalibrationError(
                f"{where}: {name} differs from nominal by {delta[i]:.6g} {unit}, more than "
                f"{PLAUSIBLE_DELTA[unit]:g} {unit}: a unit mistake or the wrong nominal model?"
            )


def _flat_values(mdh, base2tracker, tool):
    base = np.concatenate([base2tracker[:3, 3], rotations.angles_xyz(base2tracker[:3, :3])])
    # Tool rotation as Rx Ry Rz angles of flange2tool, like the base frame's (issue 9).
    turn = rotations.angles_xyz(tool[:3, :3])
    return np.concatenate([np.asarray(mdh).ravel(), base, tool[:3, 3], turn])


def _jsonable(value):
    """numpy scalars and arrays, tuples and dataclass-free objects as JSON values."""
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return _jsonable(value.tolist())
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.floating):
        return float(value)
    if value is None or isinstance(value, bool | int | float | str):
        return value
    if hasattr(value, "__dict__"):
        return _jsonable({k: v for k, v in vars(value).items() if not k.startswith("_")})
    return str(value)
