"""Writers of the compensated parameters in the formats robot users load."""

import csv
import io
import json

import numpy as np

from calibrator import kinematics

FORMATS = ("json", "csv")
_FIELDS = kinematics.FIELDS


def to_json(doc):
    """Compensated MDH table with nominal values and deltas, as JSON text."""
    mdh, nominal = doc["mdh_array"], doc["nominal_array"]
    out = {
        "model": doc.get("model"),
        "convention": "A_i = Rz(theta_i + q_i) Tz(d_i) Tx(a_i) Rx(alpha_i) Ry(beta_i)",
        "joints": [
            {
                "joint": j + 1,
                **{f: float(mdh[j, c]) for c, f in enumerate(_FIELDS)},
                "nominal": {f: float(nominal[j, c]) for c, f in enumerate(_FIELDS)},
            }
            for j in range(6)
        ],
        "base2tracker": doc["base2tracker"],
        "flange2tool": doc["flange2tool"],
    }
    return json.dumps(out, indent=2) + "\n"


def to_csv(doc):
    """One row per joint: compensated values, nominal values and deltas."""
    mdh, nominal = doc["mdh_array"], doc["nominal_array"]
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(
        ["joint", *_FIELDS, *(f"nominal_{f}" for f in _FIELDS), *(f"delta_{f}" for f in _FIELDS)]
    )
    for j in range(6):
        writer.writerow(
            [
                j + 1,
                *(_num(v) for v in mdh[j]),
                *(_num(v) for v in nominal[j]),
                *(_num(v) for v in mdh[j] - nominal[j]),
            ]
        )
    return buf.getvalue()


def _num(value):
    return repr(float(np.round(value, 12)))


def export(doc, fmt):
    """Text of the compensated parameters in format ``fmt`` (one of :data:`FORMATS`)."""
    return {"json": to_json, "csv": to_csv}[fmt](doc)
