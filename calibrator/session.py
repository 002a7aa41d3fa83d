"""Session file v1: one Parquet row per measured pose, metadata in the footer.

Columns (units in the names):

=================== ========= ==================================================
column              required  meaning
=================== ========= ==================================================
``pose``            yes       pose number (int, unique)
``q1_rad..q6_rad``  yes       joint angles read back from the robot
``x_mm y_mm z_mm``  yes       mean tool point over the readings, tracker frame
``rx_rad ry_rad     no        rotation vector of the probe frame in the tracker
rz_rad``                      frame (6-DoF probes); all three or none
``sx_mm sy_mm       no        standard deviation of the readings per axis
sz_mm``
``n_readings``      no        readings averaged into the row
``timestamp``       no        when the pose was measured
``air_temperature_c no        the measuring conditions the devices reported
air_pressure_hpa              at the pose (null where they did not): the air
air_humidity_pct              at the tracker (degC, hPa, %RH), the tracker's
tracker_on_s                  time since power-on (s), each joint's
j1_temperature_c              temperature (degC)
.. j6_temperature_c``
=================== ========= ==================================================

``tracker_warmed_up`` (bool, null where the tracker did not say) tells
whether the tracker said it was warmed up at the pose.
:func:`conditions_summary` sums the columns up over the session; sessions
written before these columns existed read as they always did.

The file metadata key ``calibrator`` holds JSON::

    {"format": "calibrator.session", "version": 1,
     "frame": "base" | "tracker",          # frame of x/y/z: is base2tracker unknown?
     "model": NAME,                        # and/or
     "nominal_mdh": [[a_mm, alpha_rad, theta_rad, d_mm, beta_rad] x 6],
     "flange2tool": 4x4 row-major,         # optional first guess (identity if absent)
     "tool_known": false,                  # optional: true fixes the tool frame
     "joints": "controller", ...}          # optional: the convention of q1..q6

One of ``model`` and ``nominal_mdh`` is required; ``nominal_mdh`` wins when
both are present. Other keys are kept and ignored. Every known key must have
its JSON type (``"false"`` is not ``false``).

Joint angles at the boundary
----------------------------
``q1_rad..q6_rad`` are the angles the robot's controller shows (KUKA's
A1..A6, FANUC's J1..J6 with J3 from the horizon): the named arm's
controller convention (:class:`calibrator.robots.JointConvention`) turns
them into the model's angles in :attr:`Session.observations`, the only way
the kinematics reads them. ``"joints": "model"`` says a file holds the
model's own angles. A file without ``joints`` holds the controller's, as this
page always said, except one written by an earlier ``calibrator`` (its
``measured`` or ``simulated`` key): those wrote the model's angles, and are
read as such. With only ``nominal_mdh`` (no arm named) the two are the same.

Loading also checks the data against the model
(:func:`calibrator.model.plausibility.check_observations`): joints against the
joint limits, the point cloud against the arm's reach. A likely unit mistake
is refused naming the unit; doubtful cases land in :attr:`Session.warnings`.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
from numpy.typing import ArrayLike

from calibrator import outputs, robots
from calibrator.errors import CalibrationError, SessionError
from calibrator.inputs import jsonfile, session_table
from calibrator.inputs.errors import StrictError
from calibrator.model import consistency, frames, kinematics, plausibility, rotations
from calibrator.model.measurement import Observations

if TYPE_CHECKING:
    import pandas as pd


FORMAT = "calibrator.session"
VERSION = 1
META_KEY = b"calibrator"
JOINT_COLUMNS = tuple(f"q{i}_rad" for i in range(1, 7))
POINT_COLUMNS = ("x_mm", "y_mm", "z_mm")
ROTVEC_COLUMNS = ("rx_rad", "ry_rad", "rz_rad")
SPREAD_COLUMNS = ("sx_mm", "sy_mm", "sz_mm")
FRAMES = ("base", "tracker")
#: What ``q1_rad..q6_rad`` hold: the controller's angles (what the robot
#: reports and a pendant shows), or the kinematic model's own.
JOINTS = ("controller", "model")
#: Metadata keys only sessions written by ``calibrator`` carry: such a file
#: without ``joints`` was written before the key existed, in the model's angles.
_WRITTEN_BY_CALIBRATOR = ("measured", "simulated")
#: Largest standard deviation of a pose's readings (mm): a spread of a metre
#: is not a measurement of one point.
MAX_SPREAD_MM = 1000.0
#: Optional per-pose measuring conditions (:func:`to_table`'s ``conditions``): column
#: and the key of a pose's conditions it holds (joint temperatures: by joint).
CONDITION_COLUMNS = {
    "air_temperature_c": "air_temperature_c",
    "air_pressure_hpa": "air_pressure_hpa",
    "air_humidity_pct": "air_humidity_pct",
    "tracker_on_s": "on_s",
    **{f"j{j}_temperature_c": f"joint_temperatures_c[{j - 1}]" for j in range(1, 7)},
}
#: Whether the tracker said it was warmed up at the pose (bool, nullable).
WARMED_UP_COLUMN = "tracker_warmed_up"
#: The columns :func:`load` checks a table against.
_SCHEMA = session_table.Schema(
    JOINT_COLUMNS,
    POINT_COLUMNS,
    ROTVEC_COLUMNS,
    SPREAD_COLUMNS,
    tuple(CONDITION_COLUMNS),
    WARMED_UP_COLUMN,
    MAX_SPREAD_MM,
)


@dataclass(frozen=True)
class SessionMeta:
    """What the footer says about a session.

    Attributes
    ----------
    frame : {'base', 'tracker'}
        ``base``: points are in the robot base frame (base2tracker is the
        identity and not identified); ``tracker``: base2tracker is unknown.
    nominal_mdh : ndarray, shape (6, 5)
    model : str or None
    flange2tool : ndarray, shape (4, 4)
        First guess of the tool frame in the flange frame (mm).
    tool_known : bool
        Whether the tool frame is known exactly: its point and, with
        orientation data, its rotation are then fixed (not identified).
    extra : dict
        Other keys, kept as they were.
    joints : {'controller', 'model'}
        What the joint columns hold: the controller's angles (what every
        session this program writes holds) or the model's.
    joint_convention : calibrator.robots.JointConvention or None
        The controller convention the file states (``convention``); None:
        the named arm's (:func:`calibrator.robots.convention_of`).
    """

    frame: str
    nominal_mdh: np.ndarray
    model: str | None = None
    flange2tool: np.ndarray = field(default_factory=lambda: np.eye(4))
    tool_known: bool = False
    extra: dict[str, object] = field(default_factory=dict)
    joints: str = "controller"
    joint_convention: robots.JointConvention | None = None

    def __post_init__(self) -> None:
        # Frozen, arrays included: derive a changed footer with dataclasses.replace().
        for name in ("nominal_mdh", "flange2tool"):
            table = np.array(getattr(self, name), dtype=float)
            table.setflags(write=False)
            object.__setattr__(self, name, table)
        if self.joints not in JOINTS:
            raise ValueError(f"joints must be one of {JOINTS}, got {self.joints!r}")

    @property
    def convention(self) -> robots.JointConvention:
        """Controller -> model angles of the joint columns (identity for model angles)."""
        if self.joints == "model":
            return robots.JointConvention()
        if self.joint_convention is not None:
            return self.joint_convention
        return robots.convention_of(self.model)

    def to_json(self) -> dict[str, object]:
        """The footer's JSON document (the ``calibrator`` metadata key)."""
        out = dict(self.extra)
        out.update(
            format=FORMAT,
            version=VERSION,
            frame=self.frame,
            nominal_mdh=np.asarray(self.nominal_mdh).tolist(),
            flange2tool=np.asarray(self.flange2tool).tolist(),
            tool_known=bool(self.tool_known),
            joints=self.joints,
        )
        convention = self.convention
        if not convention.is_identity:
            # Stated, so the file reads right where its arm's description cannot be found.
            out["convention"] = {
                "sign": list(convention.sign),
                "offset_rad": list(convention.offset_rad),
                "couplings": [list(c) for c in convention.couplings],
            }
        if self.model:
            out["model"] = self.model
        return out


@dataclass(frozen=True)
class Session:
    """A loaded session.

    Attributes
    ----------
    table : pyarrow.Table
        The rows as stored, sorted by pose (``table.to_pandas()`` for a frame).
    meta : SessionMeta
    warnings : list of str
        Doubts about the data that did not justify refusing it (one line each).
    """

    table: pa.Table
    meta: SessionMeta
    warnings: list[str] = field(default_factory=list)

    def conditions(self) -> dict:
        """The session's measuring conditions (:func:`conditions_summary`); empty if none."""
        names = [*CONDITION_COLUMNS, WARMED_UP_COLUMN]
        present = {c: self.table[c].to_pylist() for c in names if c in self.table.column_names}
        return conditions_summary(present)

    def array(self, columns: Sequence[str]) -> np.ndarray:
        """Columns as one float array, shape (N, len(columns))."""
        return np.column_stack([session_table.floats(self.table, c) for c in columns])

    @property
    def observations(self) -> Observations:
        """The rows as :class:`calibrator.model.measurement.Observations`, in the model's angles.

        The one place a session's joint columns (the controller's angles)
        become the kinematics' (:attr:`SessionMeta.convention`).
        """
        rot = None
        if all(c in self.table.column_names for c in ROTVEC_COLUMNS):
            rot = rotations.rotvec_to_matrix(self.array(ROTVEC_COLUMNS))
        q = self.meta.convention.to_model(self.array(JOINT_COLUMNS))
        return Observations(q, self.array(POINT_COLUMNS), rot)


def load(path: outputs.PathLike, model: str | None = None) -> Session:
    """Read and validate a session file.

    Parameters
    ----------
    path : str or Path
    model : str, optional
        Named model to use instead of what the file says.

    Raises
    ------
    SessionError
        With a one-line message naming the problem: unreadable file, missing
        or mistyped metadata or columns, absurd values, or data implausible
        for the model (likely unit mistakes are named).
    """
    path = Path(path)
    if not path.is_file():
        raise SessionError(f"session file not found: {path}")
    try:
        pf = pq.ParquetFile(path)
        table = pf.read()
    except (pa.ArrowException, OSError) as exc:
        raise SessionError(f"{path} is not a readable Parquet file ({_first_line(exc)})") from None
    meta_raw = (pf.schema_arrow.metadata or {}).get(META_KEY)
    meta = _parse_meta(meta_raw, path, model)
    loaded = Session(session_table.check_table(table, path, _SCHEMA), meta)
    limits = _model_limits(meta.model)
    stated = loaded.array(JOINT_COLUMNS)
    try:
        doubts = plausibility.check_observations(
            meta.convention.to_model(stated),
            loaded.array(POINT_COLUMNS),
            meta.nominal_mdh,
            limits,
            meta.flange2tool,
            JOINT_COLUMNS,
            stated_q=stated if meta.joints == "controller" else None,
        )
    except SessionError as exc:
        raise SessionError(f"{path}: {exc}") from None
    breach = _controller_limit_breach(meta, stated)
    if breach:
        raise SessionError(f"{path}: {breach}")
    return replace(loaded, warnings=doubts)


def _controller_limit_breach(meta: SessionMeta, stated: np.ndarray) -> str:
    """A pose outside the controller's stated limits (a coupled joint's), or ""."""
    if not meta.model or meta.joints != "controller":
        return ""
    try:
        arm = robots.get(meta.model)
    except CalibrationError:
        return ""
    if arm.controller_limits_rad is None:
        return ""  # the model's limits are the whole rule: checked above
    breach = arm.limit_breach(arm.convention.to_model(stated))
    if breach is None:
        return ""
    row, what = breach
    return f"pose {row} (row) {what} (the controller's limits of the {arm.name})"


def _model_limits(name):
    """Joint limits of a named model; None for a name only ``nominal_mdh`` describes."""
    if name is None:
        return None
    try:
        return robots.get(name).joint_limits_rad
    except CalibrationError:
        return None


def _first_line(exc):
    return str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__


def _parse_meta(raw, path, model):
    if raw is None:
        raise SessionError(f"{path} has no '{META_KEY.decode()}' metadata (not a session file v1)")
    try:
        meta = jsonfile.load_json(raw, f"{path}: the '{META_KEY.decode()}' metadata")
    except StrictError as exc:
        raise SessionError(str(exc)) from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise SessionError(f"{path}: metadata format is not '{FORMAT}'")
    version = meta.get("version")
    if type(version) is not int or version != VERSION:  # true == 1 and 1.0 == 1 in Python
        raise SessionError(
            f"{path}: session version {version!r} is not supported "
            f"(this program reads version {VERSION}, a JSON integer)"
        )
    if not isinstance(meta.get("frame"), str) or meta["frame"] not in FRAMES:
        raise SessionError(
            f"{path}: metadata 'frame' must be 'base' or 'tracker', got {meta.get('frame')!r}"
        )
    if meta.get("model") is not None and not isinstance(meta["model"], str):
        raise SessionError(f"{path}: metadata 'model' must be a string, got {meta['model']!r}")
    tool_known = meta.get("tool_known", False)
    if not isinstance(tool_known, bool):
        raise SessionError(
            f"{path}: metadata 'tool_known' must be true or false (JSON booleans), "
            f"got {tool_known!r}"
        )
    extra = {k: v for k, v in meta.items() if k not in _KNOWN_KEYS}
    joints = meta.get("joints")
    if joints is None:
        # Earlier calibrator versions wrote the model's angles; everyone else was told
        # (this format's page) to write what the robot reports.
        joints = "model" if any(k in extra for k in _WRITTEN_BY_CALIBRATOR) else "controller"
    elif not isinstance(joints, str) or joints not in JOINTS:
        raise SessionError(
            f"{path}: metadata 'joints' must be 'controller' or 'model', got {joints!r}"
        )
    name = model or meta.get("model")
    try:
        if model is not None or "nominal_mdh" not in meta:
            if name is None:
                raise SessionError(f"{path}: metadata names neither 'model' nor 'nominal_mdh'")
            nominal = robots.get(name).mdh
            name = robots.get(name).name
        else:
            nominal = _matrix(meta["nominal_mdh"], (6, 5), "nominal_mdh", path)
        tool = meta.get("flange2tool")
        tool = (
            np.eye(4)
            if tool is None
            else frames.check_transform(_matrix(tool, (4, 4), "flange2tool", path), "flange2tool")
        )
        if np.any(np.abs(tool[:3, 3]) > consistency.MAX_MDH["mm"]):
            raise SessionError(
                f"{path}: metadata 'flange2tool' puts the tool more than "
                f"{consistency.MAX_MDH['mm']:g} mm from the flange"
            )
    except SessionError:
        raise
    except (CalibrationError, ValueError) as exc:
        raise SessionError(f"{path}: {exc}") from None
    stated = _stated_convention(meta.get("convention"), path)
    return SessionMeta(meta["frame"], nominal, name, tool, tool_known, extra, joints, stated)


def _stated_convention(value: Any, path: Path) -> robots.JointConvention | None:
    """The ``convention`` key as a :class:`~calibrator.robots.JointConvention` (None if absent)."""
    if value is None:
        return None
    keys = {"sign", "offset_rad", "couplings"}
    if not isinstance(value, dict) or set(value) - keys or not {"sign", "offset_rad"} <= set(value):
        raise SessionError(
            f"{path}: metadata 'convention' must hold 'sign', 'offset_rad' and 'couplings'"
        )
    couplings = value.get("couplings", [])
    if not _is_number_table([value["sign"], value["offset_rad"]]) or not (
        _is_number_table(couplings)
        and all(len(c) == 3 and c[0] == int(c[0]) and c[1] == int(c[1]) for c in couplings)
    ):
        raise SessionError(
            f"{path}: metadata 'convention' must be lists of JSON numbers "
            "(couplings: [joint, earlier joint, factor], 0-based)"
        )
    try:
        return robots.JointConvention(
            sign=tuple(float(v) for v in value["sign"]),
            offset_rad=tuple(float(v) for v in value["offset_rad"]),
            couplings=tuple((int(j), int(k), float(f)) for j, k, f in couplings),
            source="the session file",
        )
    except (CalibrationError, ValueError, OverflowError) as exc:
        raise SessionError(f"{path}: metadata 'convention': {exc}") from None


_KNOWN_KEYS = {
    "format",
    "version",
    "frame",
    "model",
    "nominal_mdh",
    "flange2tool",
    "tool_known",
    "joints",
    "convention",
}


def _matrix(value, shape, what, path):
    if not _is_number_table(value):
        raise SessionError(
            f"{path}: metadata '{what}' must be a table (list of lists) of JSON numbers"
        )
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise SessionError(f"{path}: metadata '{what}' is not a numeric table") from None
    if arr.shape != shape:
        if what == "nominal_mdh" and arr.ndim == 2 and arr.shape[1] == 5:
            raise SessionError(
                f"{path}: 'nominal_mdh' has {arr.shape[0]} joints; "
                "this program calibrates 6-axis arms"
            )
        raise SessionError(f"{path}: metadata '{what}' must be {shape}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise SessionError(f"{path}: metadata '{what}' has NaN or infinite entries")
    if what == "nominal_mdh":
        try:
            consistency.check_mdh_sane(arr, f"metadata '{what}'")
        except CalibrationError as exc:
            raise SessionError(f"{path}: {exc}") from None
    return arr


def _is_number_table(value):
    """A list of lists of int/float (not bool, not text): what JSON gives for a table."""
    return isinstance(value, list) and all(
        isinstance(row, list)
        and all(isinstance(v, int | float) and not isinstance(v, bool) for v in row)
        for row in value
    )


def to_table(
    q: ArrayLike,
    points: ArrayLike,
    rotvecs: ArrayLike | None = None,
    spread: ArrayLike | None = None,
    n_readings: ArrayLike | None = None,
    timestamps: ArrayLike | None = None,
    conditions: Sequence[dict] | None = None,
) -> pa.Table:
    """Build the rows of a session from arrays.

    Parameters
    ----------
    q : array_like, shape (N, 6)
        Joint angles as the controller states them (rad): convert the
        model's with ``arm.convention.to_controller`` first.
    points : array_like, shape (N, 3)
        Tool points, tracker frame (mm).
    rotvecs : array_like, shape (N, 3), optional
        Probe orientation as rotation vectors (rad).
    spread : array_like, shape (N, 3), optional
        Standard deviation of the readings (mm).
    n_readings : array_like, shape (N,), optional
    timestamps : array_like, shape (N,), optional
    conditions : sequence of N dict, optional
        Each pose's measuring conditions (``calibrator.acquire.rows.conditions_of``);
        a :data:`CONDITION_COLUMNS` column is written when some pose reports it,
        null where a pose does not.

    Returns
    -------
    pyarrow.Table
    """
    q = kinematics.check_joints(q)
    data: dict[str, Any] = {"pose": np.arange(len(q), dtype=np.int64)}
    data.update(zip(JOINT_COLUMNS, q.T, strict=True))
    data.update(zip(POINT_COLUMNS, np.asarray(points, dtype=float).T, strict=True))
    if rotvecs is not None:
        data.update(zip(ROTVEC_COLUMNS, np.asarray(rotvecs, dtype=float).T, strict=True))
    if spread is not None:
        data.update(zip(SPREAD_COLUMNS, np.asarray(spread, dtype=float).T, strict=True))
    if n_readings is not None:
        data["n_readings"] = np.asarray(n_readings, dtype=np.int64)
    if timestamps is not None:
        data["timestamp"] = timestamps
    for column, values in condition_columns(conditions or []).items():
        kind = pa.bool_() if column == WARMED_UP_COLUMN else pa.float64()
        data[column] = pa.array(values, kind)
    return pa.table(data)


def condition_columns(conditions: Sequence[dict]) -> dict[str, list]:
    """The condition columns some pose reports (None where a pose does not), by column name.

    Parameters
    ----------
    conditions : sequence of dict
        Each pose's conditions (``calibrator.acquire.rows.conditions_of``).
    """
    out: dict[str, list] = {}
    warm = [row.get("warmed_up") for row in conditions]
    if any(w is not None for w in warm):
        out[WARMED_UP_COLUMN] = [None if w is None else bool(w) for w in warm]
    for column, key in CONDITION_COLUMNS.items():
        name, _, index = key.partition("[")
        values = []
        for row in conditions:
            value = row.get(name)
            if value is not None and index:
                value = value[int(index[:-1])]
            values.append(None if value is None else float(value))
        if any(v is not None for v in values):
            out[column] = values
    return out


def conditions_summary(columns: dict[str, list]) -> dict:
    """The measuring conditions over a session: each column's least, mean and most.

    Parameters
    ----------
    columns : dict
        Condition columns by name (:func:`condition_columns`, or a table's),
        values per pose, None where a pose did not say.

    Returns
    -------
    dict
        ``{column: {"min", "mean", "max"}}`` for each numeric column with a
        value, ``tracker_warmed_up`` (every reporting pose warmed up, or None),
        ``poses_reporting``; empty when no pose reported anything.
    """
    out: dict = {}
    reporting = 0
    for column in CONDITION_COLUMNS:
        values = np.array([v for v in columns.get(column, []) if v is not None], dtype=float)
        if values.size:
            reporting = max(reporting, values.size)
            out[column] = {
                "min": float(values.min()),
                "mean": float(values.mean()),
                "max": float(values.max()),
            }
    warm = [w for w in columns.get(WARMED_UP_COLUMN, []) if w is not None]
    if warm:
        out[WARMED_UP_COLUMN] = all(warm)
        reporting = max(reporting, len(warm))
    if out:
        out["poses_reporting"] = reporting
    return out


def write(
    path: outputs.PathLike,
    table: pa.Table | pd.DataFrame,
    meta: SessionMeta,
    batch: outputs.Outputs | None = None,
) -> None:
    """Write a session atomically (:mod:`calibrator.outputs`).

    Parameters
    ----------
    path : str or Path
    table : pyarrow.Table or pandas.DataFrame
        Rows following the schema above.
    meta : SessionMeta
    batch : calibrator.outputs.Outputs, optional
        Write as part of this batch (all of its files or none).
    """
    arrow = (
        table if isinstance(table, pa.Table) else pa.Table.from_pandas(table, preserve_index=False)
    )
    metadata = dict(arrow.schema.metadata or {})
    metadata[META_KEY] = json.dumps(meta.to_json()).encode()
    arrow = arrow.replace_schema_metadata(metadata)
    if batch is None:
        outputs.write_with(path, lambda tmp: pq.write_table(arrow, tmp))
    else:
        batch.file(path, lambda tmp: pq.write_table(arrow, tmp))
