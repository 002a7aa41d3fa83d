"""The identified arm: :class:`Calibration`, what ``identify`` writes and exporters read.

The file layout (``calibration.json``) is documented key by key in
``docs/calibration-format.md``. In short, a JSON object with

- typed keys read into the fields of :class:`Calibration`: ``format``,
  ``version``, ``model``, ``frame``, ``session``, ``nominal_mdh``, ``mdh``,
  ``base2tracker``, ``flange2tool``, ``base0``, ``tool0``,
  ``free_parameters``, ``deltas``, ``dropped_parameters``;
- ``parameters``: one record per candidate parameter with its nominal and
  identified value and whether it was free (derived; rewritten on save);
- every other key (``stats``, ``method``, ``seed``, ``solver``, and what
  later versions of ``identify`` add) kept as it is in
  :attr:`Calibration.diagnostics`.

The file is strict JSON: a NaN or infinity anywhere refuses the save, and
:func:`load` checks types, shapes, finiteness, rigidity of the frames and
consistency of the fixed parameters before anything uses the file.
"""

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from calibrator import frames, kinematics, outputs, parameters
from calibrator.errors import CalibrationError
from calibrator.joint_terms import JointTerms

FORMAT = "calibrator.calibration"
VERSION = 1
FRAMES = ("base", "tracker")
_FIELDS = kinematics.FIELDS
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
    "joint_terms",
)
#: Refuse files larger than this: a calibration is a few kB.
MAX_BYTES = 16 * 2**20
#: A fixed parameter may differ from its nominal value by this much (rounding).
_FIXED_TOL = 1e-9
#: Identified values further than this from nominal are not a calibration of
#: that arm (a unit mistake or a wrong nominal): (mm, rad).
PLAUSIBLE_DELTA = {"mm": 100.0, "rad": 0.5}


@dataclass
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
        Identified parameters (names of :data:`calibrator.parameters.ALL_NAMES`).
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
    diagnostics : dict
        Every other key of the file (statistics, solver details, ...), JSON values.
    joint_terms : JointTerms
        Joint error terms (:mod:`calibrator.joint_terms`), zero when not used;
        written under ``"joint_terms"`` only when some term is nonzero.
    """

    nominal_mdh: np.ndarray
    mdh: np.ndarray
    base2tracker: np.ndarray = field(default_factory=lambda: np.eye(4))
    flange2tool: np.ndarray = field(default_factory=lambda: np.eye(4))
    free: tuple = ()
    deltas: dict = field(default_factory=dict)
    dropped: list = field(default_factory=list)
    model: str | None = None
    frame: str = "base"
    base0: np.ndarray = field(default_factory=lambda: np.eye(4))
    tool0: np.ndarray = field(default_factory=lambda: np.eye(4))
    session: str | None = None
    diagnostics: dict = field(default_factory=dict)
    joint_terms: JointTerms = field(default_factory=JointTerms.zero)

    def __post_init__(self):
        self.nominal_mdh = kinematics.check_mdh(self.nominal_mdh).copy()
        self.mdh = kinematics.check_mdh(self.mdh).copy()
        for name in ("base2tracker", "flange2tool", "base0", "tool0"):
            setattr(self, name, frames.check_transform(getattr(self, name), name).copy())
        self.free = tuple(self.free)

    @classmethod
    def from_result(cls, result, session_path=None, model=None, frame="base"):
        """The calibration of an identification result.

        Parameters
        ----------
        result : calibrator.identify.pipeline.Result
            Needs ``space``, ``x``, ``dropped``; every other public attribute
            (``stats``, ``details``, ``options`` and whatever later versions add,
            e.g. standard errors) goes to :attr:`diagnostics` as JSON values.
        session_path : str or Path, optional
        model : str, optional
        frame : {'base', 'tracker'}
        """
        space = result.space
        mdh, base2tracker, flange2tool = space.unpack(result.x)
        x = np.asarray(result.x, dtype=float)
        # Joint terms go under "joint_terms"; free/deltas stay geometric.
        terms = JointTerms.from_vector(space.joint_terms(x))
        geometric = [i for i, n in enumerate(space.free) if n in parameters.ALL_NAMES]
        diagnostics = {}
        opts = getattr(result, "options", None)
        if opts is not None:
            diagnostics.update(
                method=opts.method, seed=opts.seed, validation_fraction=opts.validation_fraction
            )
            if hasattr(opts, "loss"):
                diagnostics["loss"] = opts.loss
        known = {"space", "x", "dropped", "options", "fit_index", "validation_index", "details"}
        for key, value in vars(result).items():
            if key not in known and not key.startswith("_"):
                diagnostics[key] = value
        if hasattr(result, "validation_index"):
            diagnostics["validation_poses"] = [int(i) for i in result.validation_index]
        if getattr(result, "details", None) is not None:
            diagnostics["solver"] = result.details
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
            diagnostics=_jsonable(diagnostics),
            joint_terms=terms,
        )

    def parameter_records(self):
        """One record per candidate parameter: nominal, identified, free or fixed.

        MDH entries hold the table values; ``base_*`` the translation (mm)
        and ``Rx Ry Rz`` angles (rad, :func:`calibrator.frames.angles_xyz`)
        of ``base2tracker`` (nominal: of ``base0``); ``tool_x/y/z`` the tool
        point in the flange frame and ``tool_rx/ry/rz`` the angles of its
        rotation (nominal: of ``tool0``).

        Returns
        -------
        list of dict
            ``{"name", "unit", "nominal", "identified", "free"}``.
        """
        nominal = _flat_values(self.nominal_mdh, self.base0, self.tool0)
        identified = _flat_values(self.mdh, self.base2tracker, self.flange2tool)
        free = set(self.free)
        return [
            {
                "name": name,
                "unit": parameters.unit(name),
                "nominal": float(nominal[i]),
                "identified": float(identified[i]),
                "free": name in free,
            }
            for i, name in enumerate(parameters.ALL_NAMES)
        ]

    def to_json(self):
        """The calibration.json document (plain JSON values)."""
        doc = dict(self.diagnostics)
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

    def save(self, path, batch=None):
        """Write strict JSON atomically; refuses NaN or infinity anywhere.

        With ``batch`` (an :class:`calibrator.outputs.Outputs`), as part of it.

        Raises
        ------
        CalibrationError
            Naming the first key that holds a non-finite number; nothing is written.
        """
        doc = self.to_json()
        bad = _first_non_finite(doc)
        if bad is not None:
            raise CalibrationError(
                f"refusing to write {path}: {bad} is not a finite number "
                "(calibration files are strict JSON)"
            )
        write(path, doc, batch=batch)

    @classmethod
    def load(cls, path):
        """Read and check a calibration file; see :func:`load`."""
        return load(path)


def mdh_records(mdh):
    """MDH table (6, 5) as a list of six ``{"a_mm": ..., ...}`` dicts."""
    return [dict(zip(_FIELDS, map(float, row), strict=True)) for row in np.asarray(mdh)]


def mdh_from_records(records):
    """Inverse of :func:`mdh_records`; returns an ndarray (6, 5)."""
    return np.array([[float(r[f]) for f in _FIELDS] for r in records])


def write(path, document, batch=None):
    """Write a JSON document atomically (strict JSON: ValueError on NaN/inf).

    With ``batch`` (an :class:`calibrator.outputs.Outputs`), as part of it.
    """
    text = json.dumps(document, indent=2, allow_nan=False) + "\n"
    if batch is None:
        outputs.write_text(path, text)
    else:
        batch.text(path, text)


def load(path):
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
    try:
        doc = json.loads(path.read_bytes().decode("utf-8"), parse_constant=_reject_constant)
    except _NonFinite as exc:
        raise CalibrationError(f"{path}: {exc} is not allowed (strict JSON)") from None
    except (ValueError, UnicodeDecodeError, RecursionError):
        raise CalibrationError(f"{path} is not JSON") from None
    return from_json(doc, path)


def from_json(doc, where="calibration"):
    """A :class:`Calibration` from a parsed document, validated like :func:`load`."""
    check = _Checker(where)
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise CalibrationError(f"{where} is not a calibrator calibration file")
    version = doc.get("version")
    if type(version) is not int or version != VERSION:
        raise CalibrationError(
            f"{where}: calibration version {version!r} is not supported "
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
    free = doc.get("free_parameters")
    if not isinstance(free, list) or not all(isinstance(n, str) for n in free):
        raise CalibrationError(f"{where}: 'free_parameters' must be a list of names")
    unknown = [n for n in free if n not in parameters.ALL_NAMES]
    if unknown or len(set(free)) != len(free):
        raise CalibrationError(
            f"{where}: 'free_parameters' has unknown or repeated names {unknown or free}"
        )
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
        raise CalibrationError(f"{where}: 'frame' must be 'base' or 'tracker', got {frame!r}")
    _check_fixed(mdh, nominal, free, where)
    diagnostics = {k: v for k, v in doc.items() if k not in TYPED_KEYS}
    try:
        terms = JointTerms.from_json(doc.get("joint_terms"))
    except CalibrationError as exc:
        raise CalibrationError(f"{where}: {exc}") from None
    return Calibration(
        nominal_mdh=nominal,
        mdh=mdh,
        free=tuple(free),
        deltas={k: float(v) for k, v in deltas.items()},
        dropped=dropped,
        model=doc.get("model"),
        frame=frame,
        session=doc.get("session"),
        diagnostics=diagnostics,
        joint_terms=terms,
        **transforms,
    )


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


class _Checker:
    def __init__(self, where):
        self.where = where

    def number(self, value, what):
        # bool is an int in Python; a JSON true is not a number here.
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise CalibrationError(f"{self.where}: {what} must be a number, got {value!r:.40}")
        if not math.isfinite(value) or abs(value) > 1e12:
            raise CalibrationError(f"{self.where}: {what} is not a finite, sane number")
        return float(value)

    def table(self, doc, key, shape):
        value = doc.get(key)
        rows, cols = shape
        if (
            not isinstance(value, list)
            or len(value) != rows
            or not all(isinstance(r, list) and len(r) == cols for r in value)
        ):
            raise CalibrationError(
                f"{self.where}: '{key}' must be a {rows}x{cols} table of numbers"
            )
        return np.array(
            [
                [self.number(v, f"{key}[{i}][{j}]") for j, v in enumerate(r)]
                for i, r in enumerate(value)
            ]
        )


class _NonFinite(ValueError):
    pass


def _reject_constant(name):
    raise _NonFinite(name)


def _flat_values(mdh, base2tracker, tool):
    base = np.concatenate([base2tracker[:3, 3], frames.angles_xyz(base2tracker[:3, :3])])
    # Tool rotation as Rx Ry Rz angles of flange2tool, like the base frame's (issue 9).
    turn = frames.angles_xyz(tool[:3, :3])
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


def _first_non_finite(value, where=""):
    """Path of the first NaN or infinity in a JSON value, or None."""
    if isinstance(value, float) and not math.isfinite(value):
        return where or "value"
    if isinstance(value, dict):
        items = value.items()
    elif isinstance(value, list):
        items = enumerate(value)
    else:
        return None
    for key, item in items:
        path = f"{where}[{key}]" if isinstance(key, int) else (f"{where}.{key}" if where else key)
        found = _first_non_finite(item, path)
        if found is not None:
            return found
    return None
