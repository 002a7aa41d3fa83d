"""``json`` and ``csv``: the whole model (MDH table, base and tool frames), mm and rad."""

from __future__ import annotations

import csv
import io
import json
from typing import TYPE_CHECKING

import numpy as np

from calibrator.export.registry import Exported, exporter
from calibrator.model import kinematics, rotations

if TYPE_CHECKING:
    from calibrator.calibration import Calibration


CONVENTION = "A_i = Rz(theta_i + q_i) Tz(d_i) Tx(a_i) Rx(alpha_i) Ry(beta_i)"
#: Columns of a frame in the CSV: translation, then ``Rx(rx) Ry(ry) Rz(rz)`` angles.
FRAME_FIELDS = ("x_mm", "y_mm", "z_mm", "rx_rad", "ry_rad", "rz_rad")
_FRAME_PARAMS = {"base2tracker": "base_", "flange2tool": "tool_"}
_FRAME_NAMES = {
    "base_": ("base_tx", "base_ty", "base_tz", "base_rx", "base_ry", "base_rz"),
    "tool_": ("tool_x", "tool_y", "tool_z", "tool_rx", "tool_ry", "tool_rz"),
}


@exporter("json", (".json",), "the whole model with nominal values and free flags (mm, rad)")
def to_json(cal: Calibration) -> Exported:
    """MDH table per joint (identified, nominal, free per column) and both frames."""
    free = set(cal.free)
    out = {
        "model": cal.model,
        "convention": CONVENTION,
        "units": {"length": "mm", "angle": "rad"},
        "joints": [
            {
                "joint": j + 1,
                **{f: float(cal.mdh[j, c]) for c, f in enumerate(kinematics.FIELDS)},
                "nominal": {
                    f: float(cal.nominal_mdh[j, c]) for c, f in enumerate(kinematics.FIELDS)
                },
                "free": {
                    f: f"{col}{j + 1}" in free
                    for f, col in zip(kinematics.FIELDS, kinematics.COLUMNS, strict=True)
                },
            }
            for j in range(6)
        ],
        "base2tracker": cal.base2tracker.tolist(),
        "flange2tool": cal.flange2tool.tolist(),
        "nominal_frames": {"base2tracker": cal.base0.tolist(), "flange2tool": cal.tool0.tolist()},
        "free_frames": {
            "base2tracker": [n for n in _FRAME_NAMES["base_"] if n in free],
            "flange2tool": [n for n in _FRAME_NAMES["tool_"] if n in free],
        },
        "frames": "base2tracker maps base to tracker coordinates; flange2tool flange to tool",
    }
    return Exported(json.dumps(out, indent=2, allow_nan=False) + "\n")


def frame_values(transform: np.ndarray) -> np.ndarray:
    """``x_mm, y_mm, z_mm, rx_rad, ry_rad, rz_rad`` of a transform, shape (6,)."""
    return np.concatenate([transform[:3, 3], rotations.angles_xyz(transform[:3, :3])])


@exporter("csv", (".csv",), "one row per parameter: nominal, identified, delta, free (mm, rad)")
def to_csv(cal: Calibration) -> Exported:
    """Long table: ``element, parameter, nominal, identified, delta, free``.

    ``element`` is ``joint1``..``joint6``, ``base2tracker`` or ``flange2tool``;
    ``parameter`` carries its unit (``a_mm``, ``rx_rad``). A frame is
    ``Trans(x, y, z) . Rx(rx) . Ry(ry) . Rz(rz)``; its nominal is the first guess.
    ``delta`` is :meth:`calibrator.calibration.Calibration.all_deltas`, as in the report and
    calibration.json: a frame's delta is its move from nominal expressed in
    the nominal frame (``inv(nominal) @ identified``; for the tool point, in
    the flange frame), so for a rotated base it is not ``identified - nominal``.
    """
    free = set(cal.free)
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(["element", "parameter", "nominal", "identified", "delta", "free"])
    for j in range(6):
        for c, (field, col) in enumerate(zip(kinematics.FIELDS, kinematics.COLUMNS, strict=True)):
            nom, val = cal.nominal_mdh[j, c], cal.mdh[j, c]
            writer.writerow(
                [
                    f"joint{j + 1}",
                    field,
                    _num(nom),
                    _num(val),
                    _num(val - nom),
                    int(f"{col}{j + 1}" in free),
                ]
            )
    delta = cal.all_deltas()
    for element, nominal in (("base2tracker", cal.base0), ("flange2tool", cal.tool0)):
        identified = frame_values(getattr(cal, element))
        nominal = frame_values(nominal)
        names = _FRAME_NAMES[_FRAME_PARAMS[element]]
        for k, field in enumerate(FRAME_FIELDS):
            writer.writerow(
                [
                    element,
                    field,
                    _num(nominal[k]),
                    _num(identified[k]),
                    _num(delta[names[k]]),
                    int(names[k] in free),
                ]
            )
    return Exported(buf.getvalue())


def _num(value):
    # repr keeps every digit: the CSV reproduces the model exactly.
    return repr(float(value))
