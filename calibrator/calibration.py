"""calibration.json: what ``identify`` writes and ``export-params`` reads.

::

    {"format": "calibrator.calibration", "version": 1,
     "model": NAME or null, "nominal_mdh": [[a_mm, alpha_rad, theta_rad, d_mm, beta_rad] x 6],
     "mdh": [{"a_mm", "alpha_rad", "theta_rad", "d_mm", "beta_rad"} x 6],
     "base2tracker": 4x4, "flange2tool": 4x4,          # row-major nested lists, mm
     "free_parameters": [names], "deltas": {name: value},
     "dropped_parameters": [{"name", "reason"}],
     "stats": {"fit"|"validation": {"before"|"after": {...}}},
     "method": ..., "seed": ..., "k": ..., "session": path, ...}
"""

import json
from pathlib import Path

import numpy as np

from calibrator import kinematics, outputs
from calibrator.errors import CalibrationError

FORMAT = "calibrator.calibration"
VERSION = 1
_FIELDS = kinematics.FIELDS


def mdh_records(mdh):
    """MDH table (6, 5) as a list of six ``{"a_mm": ..., ...}`` dicts."""
    return [dict(zip(_FIELDS, map(float, row), strict=True)) for row in np.asarray(mdh)]


def mdh_from_records(records):
    """Inverse of :func:`mdh_records`; returns an ndarray (6, 5)."""
    return np.array([[float(r[f]) for f in _FIELDS] for r in records])


def to_json(result, session_path, model):
    """The calibration.json document of an identification result."""
    opts = result.options
    return {
        "format": FORMAT,
        "version": VERSION,
        "model": model,
        "session": str(session_path),
        "nominal_mdh": np.asarray(result.space.nominal_mdh).tolist(),
        "mdh": mdh_records(result.mdh),
        "base2tracker": np.asarray(result.base2tracker).tolist(),
        "flange2tool": np.asarray(result.flange2tool).tolist(),
        "free_parameters": list(result.space.free),
        "deltas": dict(zip(result.space.free, map(float, result.x), strict=True)),
        "dropped_parameters": result.dropped,
        "stats": result.stats,
        "method": opts.method,
        "seed": opts.seed,
        "k": result.k,
        "validation_fraction": opts.validation_fraction,
        "validation_poses": [int(i) for i in result.validation_index],
        "solver": result.details,
    }


def write(path, document, batch=None):
    """Write a calibration document atomically (:mod:`calibrator.outputs`).

    With ``batch`` (an :class:`calibrator.outputs.Outputs`), as part of it.
    """
    text = json.dumps(document, indent=2) + "\n"
    if batch is None:
        outputs.write_text(path, text)
    else:
        batch.text(path, text)


def load(path):
    """Read and check a calibration.json; raises CalibrationError with one line."""
    path = Path(path)
    if not path.is_file():
        raise CalibrationError(f"calibration file not found: {path}")
    try:
        doc = json.loads(path.read_text())
    except (ValueError, UnicodeDecodeError):
        raise CalibrationError(f"{path} is not JSON") from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise CalibrationError(f"{path} is not a calibrator calibration file")
    if doc.get("version") != VERSION:
        raise CalibrationError(
            f"{path}: calibration version {doc.get('version')!r} "
            f"is not supported (this program reads version {VERSION})"
        )
    try:
        mdh = mdh_from_records(doc["mdh"])
        nominal = np.asarray(doc["nominal_mdh"], dtype=float)
        if mdh.shape != (6, 5) or nominal.shape != (6, 5):
            raise ValueError
    except (KeyError, TypeError, ValueError):
        raise CalibrationError(
            f"{path}: 'mdh'/'nominal_mdh' are not six joints of "
            "a_mm, alpha_rad, theta_rad, d_mm, beta_rad"
        ) from None
    doc["mdh_array"], doc["nominal_array"] = mdh, nominal
    return doc
