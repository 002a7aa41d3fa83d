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

    from calibrator.model import consistency

    consistency.check_calibration(cal, "cal.json", ur10e.mdh)  # the catalogue's table of cal.model
    consistency.check_session_matches(cal, session.meta)       # before drawing one over the other

The caller looks a named model up in the catalogue (this package sits below
the arm's model, :mod:`calibrator.inputs`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from calibrator.inputs import messages
from calibrator.inputs.errors import ConsistencyError
from calibrator.model import kinematics

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
_MDH_NAMES = kinematics.MDH_NAMES
#: Unit of each MDH entry by name.
_MDH_UNITS = dict(zip(_MDH_NAMES, kinematics.UNITS * kinematics.N_JOINTS, strict=True))


def check_calibration(
    cal: Any, where: str = "calibration", model_mdh: np.ndarray | None = None
) -> None:
    """Refuse a calibration whose parts disagree.

    Parameters
    ----------
    cal : calibrator.calibration.Calibration
        Any object with ``model`` (str or None), ``nominal_mdh`` and ``mdh``
        (6, 5) (mm, rad), ``free`` (names) and ``deltas``
        (``{name: value}``, mm or rad).
    where : str
        Named in the error (the file's path).
    model_mdh : ndarray, shape (6, 5), optional
        The catalogue's MDH table of ``cal.model`` (mm, rad); None when the
        name is not a catalogue arm's (the file's table describes it).

    Raises
    ------
    ConsistencyError
        ``model`` names a catalogue arm whose table is not ``nominal_mdh``;
        a delta differs from what the tables and frames give.
    """
    check_mdh_sane(cal.nominal_mdh, f"{where}: 'nominal_mdh'")
    check_mdh_sane(cal.mdh, f"{where}: 'mdh'")
    check_model_table(cal.model, model_mdh, cal.nominal_mdh, f"{where}: 'nominal_mdh'")
    # MDH deltas only: frame deltas are relative to first guesses (base0, tool0)
    # that older files do not record, so they cannot be re-derived from every file.
    derived = dict(zip(_MDH_NAMES, (cal.mdh - cal.nominal_mdh).ravel(), strict=True))
    for name in cal.free:
        if name not in derived:
            continue
        stored, value = float(cal.deltas[name]), float(derived[name])
        unit = _MDH_UNITS[name]
        if not abs(stored - value) <= DERIVED_TOL[unit] * max(1.0, abs(value)):
            raise ConsistencyError(
                f"{where}: deltas.{name} is {stored:.9g} {unit} but mdh minus nominal_mdh "
                f"gives {value:.9g} {unit} (a hand-edited 'deltas' block?)"
            )


def check_mdh_sane(table: Any, what: str) -> np.ndarray:
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
            f"{what}: {_MDH_NAMES[joint * arr.shape[-1] + col]} = {arr[joint, col]:.6g} "
            f"{unit} is beyond {MAX_MDH[unit]:g} {unit}: not an arm's table"
        )
    return arr


def check_session_matches(cal: Any, meta: Any, where: str = "session") -> None:
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
        raise ConsistencyError(
            f"{where} is of {messages.a_or_an(meta.model)}, the calibration of "
            f"{messages.a_or_an(cal.model)}"
        )
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


def check_model_table(
    model: str | None, model_mdh: np.ndarray | None, table: Any, what: str
) -> None:
    """Refuse a table said to be ``model``'s that is further than :data:`MODEL_TOL` from it.

    Parameters
    ----------
    model : str or None
        The name the document gives, for the error.
    model_mdh : ndarray, shape (6, 5), or None
        The catalogue's table of ``model`` (mm, rad); None (a name only the
        table itself describes, or no name) passes.
    table : array_like, shape (6, 5)
        MDH table (mm, rad).
    what : str
        Named in the error.

    Raises
    ------
    ConsistencyError
    """
    if model is None or model_mdh is None:
        return  # a name only the table itself describes
    gap = _table_gap(model_mdh, table)
    if gap is not None:
        raise ConsistencyError(f"{what} is not a {model} ({gap}): the wrong 'model'?")


def _table_gap(expected: np.ndarray, table: np.ndarray) -> str | None:
    """The largest difference beyond :data:`MODEL_TOL` between two MDH tables, as text."""
    diff = np.abs(np.asarray(table, dtype=float) - np.asarray(expected, dtype=float))
    angles = [kinematics.ALPHA, kinematics.THETA, kinematics.BETA]
    for unit, cols in (("mm", list(_LENGTH_COLUMNS)), ("rad", angles)):
        part = np.where(np.isin(np.arange(5), cols), diff, 0.0)
        if not np.all(part <= MODEL_TOL[unit]):
            joint, col = np.unravel_index(
                int(np.nanargmax(np.nan_to_num(part, nan=np.inf))), part.shape
            )
            name = _MDH_NAMES[joint * len(kinematics.FIELDS) + col]
            return f"{name} differs by {part[joint, col]:.4g} {unit}"
    return None
