"""``ur-calibration``: per-joint DH deltas against UR's published DH, as UR keeps them.

A Universal Robots controller stores its factory calibration as deltas
``delta_theta, delta_a, delta_d, delta_alpha`` (radians, metres) per joint,
added to the model's published standard-DH table. Standard DH has no
``beta``: where two axes are nearly parallel the common normal lies far
away, so ``d`` becomes huge (hundreds of metres in real factory data) and
``a``/``theta`` jump. :func:`calibrator.model.conventions.mdh_to_dh` and
:func:`calibrator.model.conventions.dh_to_mdh` convert exactly through the joint axes;
``docs/exports.md`` gives the formulas.

File layout (an INI text, the ``[mounting]`` section as on the controller)::

    [mounting]
    delta_theta = [6 numbers]   # rad
    delta_a = [6 numbers]       # m
    delta_d = [6 numbers]       # m
    delta_alpha = [6 numbers]   # rad

    [calibrator]
    model = ur10e               # the published table the deltas are against
"""

from __future__ import annotations

import configparser
import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from calibrator.errors import CalibrationError
from calibrator.model import conventions, kinematics

if TYPE_CHECKING:
    from calibrator.calibration import Calibration

from calibrator import robots
from calibrator.export.registry import Exported, exporter
from calibrator.inputs import jsonfile, textfile
from calibrator.inputs.errors import StrictError
from calibrator.robots import ur as ur_family

#: Keys of the deltas and the MDH column each applies to, in file order.
KEYS = (
    ("delta_theta", kinematics.THETA),
    ("delta_a", kinematics.A),
    ("delta_d", kinematics.D),
    ("delta_alpha", kinematics.ALPHA),
)
_M = 1000.0  # mm per metre
#: Refuse UR calibration files larger than this: one is a few hundred bytes.
MAX_BYTES = 2**20
_ANGLES = (kinematics.THETA, kinematics.ALPHA)


def ur_models() -> tuple[str, ...]:
    """Named models of the UR family (a published UR DH table the deltas are against)."""
    return tuple(n for n in robots.names() if robots.get(n).family == ur_family.FAMILY)


def nominal_dh(model: str | None) -> np.ndarray:
    """Published standard-DH table of a UR model (mm, rad), shape (6, 5)."""
    if model is None or str(model).lower() not in ur_models():
        raise CalibrationError(
            f"the UR calibration form needs a UR model ({', '.join(ur_models())}); got {model!r}"
        )
    return robots.get(model).mdh


def deltas_from_mdh(mdh: ArrayLike, model: str | None) -> tuple[np.ndarray, np.ndarray]:
    """UR deltas (mm, rad) of an MDH table, and the residual of the conversion.

    Returns
    -------
    deltas : ndarray, shape (6, 5)
        Standard DH minus the published table; angles within (-pi, pi].
    residual : ndarray, shape (4, 4)
        ``A(mdh)(q) = A(nominal + deltas)(q) @ residual`` (identity if exact).
    """
    nominal = nominal_dh(model)
    dh, residual = conventions.mdh_to_dh(mdh, nominal)
    deltas = dh - nominal
    deltas[:, _ANGLES] = (deltas[:, _ANGLES] + np.pi) % (2 * np.pi) - np.pi
    return deltas, residual


def mdh_from_deltas(
    deltas: ArrayLike, model: str | None, reference: ArrayLike | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """MDH table (Hayati where axes are parallel) of UR deltas.

    Parameters
    ----------
    deltas : array_like, shape (6, 5)
        Deltas in MDH columns (mm, rad); the ``beta`` column must be zero.
    model : str
        UR model the deltas are against.
    reference : array_like, shape (6, 5), optional
        Table whose branches and Hayati ``d`` values to keep (the published one).

    Returns
    -------
    mdh : ndarray, shape (6, 5)
    residual : ndarray, shape (4, 4)
    """
    nominal = nominal_dh(model)
    return conventions.dh_to_mdh(
        nominal + np.asarray(deltas, dtype=float), nominal if reference is None else reference
    )


@exporter("ur-calibration", (".urcal", ".conf"), "UR factory-calibration DH deltas (m, rad)")
def to_ur(cal: Calibration) -> Exported:
    """The calibrated arm as deltas against the published DH of ``cal.model``."""
    deltas, residual = deltas_from_mdh(cal.mdh, cal.model)
    lines = [
        "# Universal Robots calibration form: DH deltas against the published",
        f"# standard-DH table of {cal.model}, written by calibrator. Metres and radians.",
        "# The tool (flange2tool) and the base placement are not part of this form.",
        "[mounting]",
    ]
    for key, col in KEYS:
        values = deltas[:, col] / (_M if col in (kinematics.A, kinematics.D) else 1.0)
        lines.append(f"{key} = [{', '.join(repr(float(v)) for v in values)}]")
    lines += ["", "[calibrator]", f"model = {cal.model}", ""]
    return Exported("\n".join(lines), _residual_notes(residual, "ur-calibration", "beta6"))


def _residual_notes(residual, fmt, what):
    mm, rad = conventions.residual_size(residual)
    if mm < 1e-9 and rad < 1e-12:
        return []
    return [f"{fmt} cannot hold {what}: the flange is off by {mm:.6g} mm and {rad:.6g} rad"]


def read(path: str | Path, model: str | None = None) -> tuple[np.ndarray, str]:
    """Read a UR calibration file.

    Parameters
    ----------
    path : str or Path
    model : str, optional
        UR model, if the file does not name it.

    Returns
    -------
    deltas : ndarray, shape (6, 5)
        In MDH columns (mm, rad), ``beta`` zero.
    model : str

    Raises
    ------
    CalibrationError
        One line naming what is wrong.
    """
    # No interpolation: a '%' in a value is text, not a configparser reference.
    parser = configparser.ConfigParser(interpolation=None)
    try:
        parser.read_string(textfile.read_text(path, MAX_BYTES, "a UR calibration file"), str(path))
    except configparser.Error as exc:
        raise CalibrationError(
            f"{path}: not a UR calibration file ({str(exc).splitlines()[0]})"
        ) from None
    if not parser.has_section("mounting"):
        raise CalibrationError(f"{path}: no [mounting] section with DH deltas")
    named = parser.get("calibrator", "model", fallback=None)
    model = model or named
    if named and model and named.lower() != model.lower():
        raise CalibrationError(f"{path}: the deltas are against {named}, not {model}")
    deltas = np.zeros((6, 5))
    for key, col in KEYS:
        raw = parser.get("mounting", key, fallback=None)
        if raw is None:
            raise CalibrationError(f"{path}: [mounting] has no {key}")
        try:
            values = jsonfile.load_json(raw, f"{path}: {key}")
        except StrictError:
            values = None  # NaN, 1e400, an integer beyond 64 bits: all refused below
        if (
            not isinstance(values, list)
            or len(values) != 6
            or not all(
                isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
                for v in values
            )
        ):
            raise CalibrationError(f"{path}: {key} must be a list of six finite numbers")
        deltas[:, col] = np.asarray(values, dtype=float) * (
            _M if col in (kinematics.A, kinematics.D) else 1.0
        )
    nominal_dh(model)  # refuses a missing or non-UR model
    assert model is not None
    return deltas, model.lower()
