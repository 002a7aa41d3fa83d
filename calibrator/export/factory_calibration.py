"""A factory calibration as the nominal model: UR DH deltas or a ROS kinematics YAML.

Starting an identification from the robot's own factory calibration, rather
than the catalogue table, measures what the factory calibration leaves.
Both formats are converted exactly to an MDH table through the joint axes
(:mod:`calibrator.model.conventions`), keeping the catalogue table's structure
(Hayati's ``beta`` where its axes are parallel) so the same parameters are
identified.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from calibrator.errors import CalibrationError
from calibrator.export import ros, ur
from calibrator.model import consistency, conventions, kinematics

if TYPE_CHECKING:
    from calibrator.session import SessionMeta


@dataclass(frozen=True)
class Nominal:
    """An imported nominal model.

    Attributes
    ----------
    mdh : ndarray, shape (6, 5)
        Nominal MDH table (mm, rad).
    base2frame0 : ndarray, shape (4, 4)
        MDH frame 0 in the file's base frame (identity unless the file moves
        or tilts joint 1's axis off the base z axis).
    flange_offset : ndarray, shape (4, 4)
        File's flange frame in the MDH flange frame: what an MDH table
        cannot hold (identity for UR deltas); goes into the tool frame.
    source : str
        ``"ur-calibration"`` or ``"ros-kinematics"``.
    model : str or None
        UR model the file is against, if it says.
    """

    mdh: np.ndarray
    base2frame0: np.ndarray
    flange_offset: np.ndarray
    source: str
    model: str | None = None


def load(path: str | Path, reference: ArrayLike | None = None, model: str | None = None) -> Nominal:
    """Read a UR calibration file or a ROS kinematics YAML as a nominal model.

    Parameters
    ----------
    path : str or Path
        ``*.yaml``/``*.yml``: ROS kinematics; anything else: UR deltas.
    reference : array_like, shape (6, 5), optional
        Catalogue MDH table whose structure and branches to keep; defaults
        to the named ``model``'s table.
    model : str, optional
        UR model (for UR deltas that do not name theirs, and as reference).

    Returns
    -------
    Nominal

    Raises
    ------
    CalibrationError
    """
    path = Path(path)
    if not path.is_file():
        raise CalibrationError(f"nominal file not found: {path}")
    if path.suffix.lower() in (".yaml", ".yml"):
        if reference is None:
            reference = ur.nominal_dh(model)
        joints, flange = ros.read(path)
        mdh, base, offset = conventions.fit_links(
            joints, flange, reference, kinematics.parallel_axes(reference, tol=0.1), beta6=True
        )
        source = "ros-kinematics"
    else:
        deltas, model = ur.read(path, model)
        mdh, offset = ur.mdh_from_deltas(deltas, model, reference)
        base, source = np.eye(4), "ur-calibration"
    if not (np.all(np.isfinite(mdh)) and np.all(np.isfinite(offset))):
        raise CalibrationError(f"{path}: the kinematics do not describe a 6R arm")
    consistency.check_mdh_sane(mdh, str(path))
    return Nominal(mdh, base, offset, source, model)


def apply(meta: SessionMeta, path: str | Path) -> tuple[SessionMeta, str]:
    """A session's footer with an imported factory calibration as its nominal model.

    Parameters
    ----------
    meta : calibrator.session.SessionMeta
        The session's footer (not changed).
    path : str or Path

    Returns
    -------
    meta : calibrator.session.SessionMeta
        ``meta`` with the imported ``nominal_mdh`` (mm, rad), and a
        ``flange2tool`` that gains what the MDH table cannot hold of the
        file's flange (mm).
    line : str
        One line saying what was imported.

    Raises
    ------
    CalibrationError
        If the file moves joint 1's axis off the base frame and the session's
        points are in the base frame (that offset would be silently lost).
    """
    imported = load(path, reference=meta.nominal_mdh, model=meta.model)
    mm, rad = conventions.residual_size(imported.base2frame0)
    if meta.frame == "base" and (mm > 1e-6 or rad > 1e-9):
        raise CalibrationError(
            f"{path} moves joint 1's axis by {mm:.3g} mm, {rad:.3g} rad from its base frame; "
            "a session in the base frame cannot take it (measure in the tracker frame)"
        )
    against = f" against {imported.model}" if imported.model else ""
    line = f"nominal model from {path} ({imported.source}{against})"
    applied = replace(
        meta,
        nominal_mdh=imported.mdh,
        flange2tool=imported.flange_offset @ meta.flange2tool,
    )
    return applied, line
