"""Cross-checks between what a document says and what it holds.

A calibration names its model, carries the nominal MDH table it started
from, the identified table and frames, and the identified ``deltas``; a
session names its model and carries its own nominal table. Each of these is
derivable from another, so a hand edit or a mix-up of files shows as a
disagreement. Refused here, in one line each:

- a calibration whose ``model`` names a catalogue arm but whose
  ``nominal_mdh`` is another arm's table (a UR10e calibration relabelled
  ``ur5e`` would export deltas against the wrong published table);
- ``deltas`` that are not what the MDH table and frames say (a hand-edited
  ``deltas`` block shown in a report while the table says otherwise);
- a calibration drawn over a session of another arm (model, nominal table
  or frame of the points).

How close is close: a factory calibration used as the nominal model
(``--nominal``) moves MDH entries by millimetres and milliradians; the
nearest two catalogue arms (UR10 and UR10e) differ by 53 mm. So a nominal
table may differ from its named model's by :data:`MODEL_TOL` and no more.
Derived values must match to rounding (:data:`DERIVED_TOL`).

Use::

    from calibrator import consistency

    consistency.check_calibration(cal)                   # after reading calibration.json
    consistency.check_session_matches(cal, session.meta)  # before drawing one over the other
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from calibrator.errors import CalibrationError
from calibrator.model import kinematics, parameters

if TYPE_CHECKING:
    from calibrator.calibration import Calibration
    from calibrator.session import SessionMeta

__all__ = [
    "check_mdh_sane",
    "check_model_table",
    "DERIVED_TOL",
    "MODEL_TOL",
    "ConsistencyError",
    "check_calibration",
    "check_session_matches",
]

#: Largest difference between a nominal table and its named model's (mm, rad).
MODEL_TOL = {"mm": 20.0, "rad": 0.05}
#: Largest MDH entry of any arm: lengths (mm) and angles (rad). Beyond these a
#: table is not an arm (and forward kinematics overflows long before 1e308).
MAX_MDH = {"mm": 1e5, "rad": 100.0}
#: Largest difference between a stored derived value and what it derives from (mm, rad).
DERIVED_TOL = {"mm": 1e-6, "rad": 1e-9}
_LENGTH_COLUMNS = (kinematics.A, kinematics.D)


class ConsistencyError(CalibrationError):
    """Two parts of the inputs that must agree do not."""


def check_calibration(cal: Calibration, where: str = "calibration") -> None:
    """Refuse a calibration whose parts disagree.

    Parameters
    ----------
    cal : calibrator.calibration.Calibration
        Any object with ``model`` (str or None), ``nominal_mdh`` and ``mdh``
        (6, 5) (mm, rad), ``free`` (names) and ``deltas``
        (``{name: value}``, mm or rad).
    where : str
        Named in the error (the file's path).

    Raises
    ------
    ConsistencyError
        ``model`` names a catalogue arm whose table is not ``nominal_mdh``;
        a delta differs from what the tables and frames give.
    """
    check_mdh_sane(cal.nominal_mdh, f"{where}: 'nominal_mdh'")
    check_mdh_sane(cal.mdh, f"{where}: 'mdh'")
    check_model_table(cal.model, cal.nominal_mdh, f"{where}: 'nominal_mdh'")
    # MDH deltas only: frame deltas are relative to first guesses (base0, tool0)
    # that older files do not record, so they cannot be re-derived from every file.
    derived = dict(zip(parameters.MDH_NAMES, (cal.mdh - cal.nominal_mdh).ravel(), strict=True))
    for name in cal.free:
        if name not in derived:
            continue
        stored, value = float(cal.deltas[name]), float(derived[name])
        unit = parameters.unit(name)
        if not abs(stored - value) <= DERIVED_TOL[unit] * max(1.0, abs(value)):
            raise ConsistencyError(
                f"{where}: deltas.{name} is {stored:.9g} {unit} but mdh minus nominal_mdh "
                f"gives {value:.9g} {unit} (a hand-edited 'deltas' block?)"
            )


def check_mdh_sane(table: ArrayLike, what: str) -> np.ndarray:
    """Refuse an MDH table that cannot be an arm's: entries beyond :data:`MAX_MDH`.

    Parameters
    ----------
    table : array_like, shape (6, 5)
        MDH table (mm, rad), already checked for shape and finiteness.
    what : str
        Named in the error (``"session.parquet: metadata 'nominal_mdh'"``).

    Returns
    -------
    ndarray, shape (6, 5)
        The table as floats.

    Raises
    ------
    ConsistencyError
    """
    arr = np.asarray(table, dtype=float)
    lengths = np.isin(np.arange(arr.shape[-1]), _LENGTH_COLUMNS)
    limit = np.where(lengths, MAX_MDH["mm"], MAX_MDH["rad"])
    bad = ~(np.abs(arr) <= limit)
    if bad.any():
        joint, col = (int(i) for i in np.argwhere(bad)[0])
        unit = "mm" if lengths[col] else "rad"
        raise ConsistencyError(
            f"{what}: {parameters.MDH_NAMES[joint * arr.shape[-1] + col]} = {arr[joint, col]:.6g} "
            f"{unit} is beyond {MAX_MDH[unit]:g} {unit}: not an arm's table"
        )
    return arr


def check_session_matches(cal: Calibration, meta: SessionMeta, where: str = "session") -> None:
    """Refuse a session that is not of the calibration's arm.

    Parameters
    ----------
    cal : calibrator.calibration.Calibration
    meta : calibrator.session.SessionMeta
        ``model``, ``nominal_mdh`` (6, 5) and ``frame``.
    where : str
        Named in the error (the session's path).

    Raises
    ------
    ConsistencyError
        Different models, nominal tables further apart than :data:`MODEL_TOL`
        (a factory calibration as nominal stays within it), or points in
        another frame.
    """
    if cal.model and meta.model and cal.model.lower() != meta.model.lower():
        raise ConsistencyError(f"{where} is of a {meta.model}, the calibration of a {cal.model}")
    gap = _table_gap(cal.nominal_mdh, meta.nominal_mdh)
    if gap is not None:
        raise ConsistencyError(
            f"{where}: its nominal MDH table is not the calibration's ({gap}): another arm?"
        )
    if cal.frame != meta.frame:
        raise ConsistencyError(
            f"{where} records points in the {meta.frame} frame, "
            f"the calibration was identified in the {cal.frame} frame"
        )


def check_model_table(model: str | None, table: ArrayLike, what: str) -> None:
    """Refuse a table said to be ``model``'s that is further than :data:`MODEL_TOL` from it.

    Parameters
    ----------
    model : str or None
        A catalogue name (others, and None, pass: the table describes them).
    table : array_like, shape (6, 5)
        MDH table (mm, rad).
    what : str
        Named in the error.

    Raises
    ------
    ConsistencyError
    """
    from calibrator import robots

    if model is None or model.lower() not in robots.names():
        return  # a name only the table itself describes
    gap = _table_gap(robots.get(model).mdh, table)
    if gap is not None:
        raise ConsistencyError(f"{what} is not a {model} ({gap}): the wrong 'model'?")


def _table_gap(expected: ArrayLike, table: ArrayLike) -> str | None:
    """The largest difference beyond :data:`MODEL_TOL` between two MDH tables, as text."""
    diff = np.abs(np.asarray(table, dtype=float) - np.asarray(expected, dtype=float))
    angles = [kinematics.ALPHA, kinematics.THETA, kinematics.BETA]
    for unit, cols in (("mm", list(_LENGTH_COLUMNS)), ("rad", angles)):
        part = np.where(np.isin(np.arange(5), cols), diff, 0.0)
        if not np.all(part <= MODEL_TOL[unit]):
            joint, col = np.unravel_index(
                int(np.nanargmax(np.nan_to_num(part, nan=np.inf))), part.shape
            )
            name = parameters.MDH_NAMES[joint * len(kinematics.FIELDS) + col]
            return f"{name} differs by {part[joint, col]:.4g} {unit}"
    return None
