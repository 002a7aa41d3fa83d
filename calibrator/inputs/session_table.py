"""The table of a session file: its columns and rows checked before anything reads them.

A session's Parquet table is refused in one line when a column is missing,
repeated, not numeric or float16 (three significant digits), when the
orientation is partial, when values are NaN, infinite or absurd (a
rotation beyond :data:`MAX_ABS_RAD`), or when pose numbers are not unique whole 64-bit numbers. The
session module hands in its column names (:class:`Schema`); the data's
plausibility for the arm is :func:`calibrator.model.plausibility.check_observations`.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
from typing import Any

import numpy as np
import pyarrow as pa

from calibrator.errors import SessionError
from calibrator.inputs.grammar import MAX_INT

__all__ = ["Schema", "check_table", "floats"]

MAX_ABS_RAD = 100.0  # 16 turns: an absurd angle (rotation vectors; joints meet their limits)


@dataclass(frozen=True)
class Schema:
    """The columns of a session table.

    Attributes
    ----------
    joints : tuple of str
        The six joint columns (rad), required.
    points : tuple of str
        The point columns ``x, y, z`` (mm), required.
    rotvec : tuple of str
        The rotation vector columns (rad): all three or none.
    spread : tuple of str
        Standard deviations of the readings (mm), optional.
    conditions : tuple of str
        Measuring conditions, numbers with nulls where a pose did not say.
    warmed_up : str
        The true/false column of the tracker's warm-up.
    max_spread_mm : float
        Largest standard deviation taken.
    """

    joints: tuple[str, ...]
    points: tuple[str, ...]
    rotvec: tuple[str, ...]
    spread: tuple[str, ...]
    conditions: tuple[str, ...]
    warmed_up: str
    max_spread_mm: float


def check_table(table: pa.Table, path: Any, schema: Schema) -> pa.Table:
    """The table of a session file, checked against ``schema`` and sorted by pose.

    Parameters
    ----------
    table : pyarrow.Table
        As read from the file.
    path : str or Path
        The file, named at the start of each error.
    schema : Schema
        The session's columns.

    Returns
    -------
    pyarrow.Table
        ``table``, sorted by its ``pose`` column (as it is when this program wrote it).

    Raises
    ------
    calibrator.errors.SessionError
        One line naming the column: repeated, missing or not numeric columns
        (float16 too), more than six joints, part of the orientation, no
        rows, NaN or infinite values, absurd orientations or spreads, pose
        numbers that are not whole, unique 64-bit integers.
    """
    names = table.column_names
    seen = set()
    for name in names:
        if name in seen:
            raise SessionError(f"{path}: column {name} appears more than once")
        seen.add(name)
    extra_joints = sorted(
        c for c in names if c.startswith("q") and c.endswith("_rad") and c not in schema.joints
    )
    if extra_joints:
        raise SessionError(
            f"{path}: columns {extra_joints} imply more than 6 joints; "
            "this program calibrates 6-axis arms"
        )
    required = ("pose",) + schema.joints + schema.points
    missing = [c for c in required if c not in names]
    if missing:
        raise SessionError(f"{path}: missing column(s) {', '.join(missing)}")
    rot_present = [c for c in schema.rotvec if c in names]
    if rot_present and len(rot_present) != 3:
        raise SessionError(
            f"{path}: orientation needs all of {', '.join(schema.rotvec)}, "
            f"found only {', '.join(rot_present)}"
        )
    if table.num_rows == 0:
        raise SessionError(f"{path}: the session has no poses")
    numeric = list(required) + rot_present + [c for c in schema.spread if c in names]
    _check_conditions(table, path, schema)
    for col in numeric:
        kind = table.schema.field(col).type
        if not (pa.types.is_integer(kind) or pa.types.is_floating(kind)):
            raise SessionError(f"{path}: column {col} is not numeric ({kind})")
        if pa.types.is_float16(kind):
            # 11 significant bits: 2500.3 mm reads back as 2500, 1.2345 rad as 1.234.
            raise SessionError(
                f"{path}: column {col} is float16 (about 3 significant digits); "
                "store float32 or float64"
            )
        if col == "pose":
            continue  # checked exactly below: large integers do not survive float64
        values = floats(table, col)
        bad = ~np.isfinite(values)
        if bad.any():
            raise SessionError(
                f"{path}: column {col} has NaN or infinite values (pose {_poses(table, bad)})"
            )
        if col in schema.rotvec and np.any(np.abs(values) > MAX_ABS_RAD):
            raise SessionError(f"{path}: column {col} has absurd values (beyond 100 rad)")
        if col in schema.spread and np.any(values < 0):
            raise SessionError(f"{path}: column {col} (a standard deviation) has negative values")
        if col in schema.spread and np.any(values > schema.max_spread_mm):
            raise SessionError(
                f"{path}: column {col} (a standard deviation) has absurd values "
                f"(beyond {schema.max_spread_mm:g} mm)"
            )
    poses = table["pose"].to_pylist()
    if any(p is None or (isinstance(p, float) and not np.isfinite(p)) for p in poses):
        raise SessionError(f"{path}: column pose has NaN, infinite or null values")
    if any(isinstance(p, float) and (p != int(p) or abs(p) > 2**53) for p in poses):
        raise SessionError(f"{path}: column pose must hold whole numbers")
    if any(abs(int(p)) > MAX_INT for p in poses):
        # uint64 above 2**63 fits no signed index (sorting, numpy, the journal).
        raise SessionError(f"{path}: column pose has numbers beyond 64-bit signed integers")
    duplicates = sorted(p for p, c in Counter(int(p) for p in poses).items() if c > 1)
    if duplicates:
        raise SessionError(f"{path}: duplicate pose number(s) {duplicates[:5]}")
    if all(a < b for a, b in zip(poses, poses[1:], strict=False)):
        # Already in order, as every session this program writes: sort_by would
        # import pyarrow.compute, a tenth of a second of every command's start.
        return table
    return table.sort_by("pose")


def _check_conditions(table, path, schema):
    """Condition columns: numbers, finite where present (a null is a pose that did not say)."""
    if schema.warmed_up in table.column_names:
        kind = table.schema.field(schema.warmed_up).type
        if not pa.types.is_boolean(kind):
            raise SessionError(f"{path}: column {schema.warmed_up} is not true/false ({kind})")
    for col in schema.conditions:
        if col not in table.column_names:
            continue
        kind = table.schema.field(col).type
        if not (pa.types.is_integer(kind) or pa.types.is_floating(kind)):
            raise SessionError(f"{path}: column {col} is not numeric ({kind})")
        values = np.array([np.nan if v is None else v for v in table[col].to_pylist()], float)
        given = np.array([v is not None for v in table[col].to_pylist()])
        if np.any(given & ~np.isfinite(values)):
            raise SessionError(f"{path}: column {col} has NaN or infinite values")


def floats(table: pa.Table, column: str) -> np.ndarray:
    """A column as float64, nulls as NaN.

    Through Python lists on purpose: pyarrow's numpy conversions import
    pandas (a third of a second), and sessions have hundreds of rows, not
    millions.
    """
    return np.array(table[column].to_pylist(), dtype=float)


def _poses(table, mask):
    return np.array(table["pose"].to_pylist())[mask][:5].tolist()
