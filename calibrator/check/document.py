"""check.json: what a check measured, what the calibration predicted, the verdict and why.

The document (format ``calibrator.check``, version 1; docs/check.md) and the
check's poses as a session file beside it (``check.parquet``: the same
columns as ``measure`` writes, so a check can be identified or compared
later) are written at once or not at all (:mod:`calibrator.outputs`).
"""

from __future__ import annotations

import json
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from calibrator import outputs
from calibrator.check import explain as explains
from calibrator.check import verdict as verdicts
from calibrator.check.model import Calibrated
from calibrator.errors import CalibrationError

if TYPE_CHECKING:
    import pyarrow as pa

    from calibrator.session import SessionMeta

FORMAT = "calibrator.check"
VERSION = 1


def data_path(output: str | Path) -> Path:
    """Where the check's poses go: ``check.parquet`` beside ``check.json``."""
    return Path(output).with_suffix(".parquet")


def measured(records: dict) -> tuple[list[int], np.ndarray, np.ndarray, np.ndarray]:
    """Poses, read-back joints (N, 6) rad, points (N, 3) mm and their standard errors (N, 3) mm.

    The standard error of an averaged point is its readings' spread over the
    root of their number.
    """
    rows = sorted(
        (r for r in records.values() if r["status"] == "measured"), key=lambda r: r["pose"]
    )
    if len(rows) < 2:
        raise CalibrationError(f"{len(rows)} check pose(s) measured: a check needs at least 2")
    q = np.array([r["q_rad"] for r in rows], float)
    points = np.array([r["point_mm"] for r in rows], float)
    spread = np.array([r["std_mm"] for r in rows], float)
    count = np.array([max(int(r.get("n_readings", 1)), 1) for r in rows], float)
    return [int(r["pose"]) for r in rows], q, points, spread / np.sqrt(count)[:, None]


def evaluate(
    model: Calibrated,
    q: np.ndarray,
    points: np.ndarray,
    stderr_mm: np.ndarray | None,
    tolerance_mm: float | None = None,
) -> dict:
    """The verdict and, when it is not ok, the explanation.

    Returns
    -------
    dict
        ``verdict`` (:class:`~calibrator.check.verdict.Verdict`), ``errors``
        (N, 3) mm, ``predicted`` (N, 3) mm, ``sd`` (N,) mm (predicted RMS
        error per pose), ``best`` (:class:`~calibrator.check.explain.Fit` or
        None) and ``tried``.
    """
    predicted = model.points(q)
    errors = points - predicted
    cov = verdicts.covariance(model.covariance(q), stderr_mm, model.sigma_mm)
    verdict = verdicts.judge(errors, cov, tolerance_mm, model.noise_dof)
    best: explains.Fit | None = None
    tried: list[explains.Fit] = []
    if verdict.verdict != "ok":
        best, tried = explains.explain(model, q, points, cov)
    sd = np.sqrt(np.einsum("nii->n", verdicts.pose_blocks(cov, len(q))))
    return {
        "verdict": verdict,
        "errors": errors,
        "predicted": predicted,
        "sd": sd,
        "best": best,
        "tried": tried,
    }


def document(
    result: dict, poses: list[int], q: np.ndarray, points: np.ndarray, *, info: dict
) -> dict:
    """The check.json document.

    ``info`` names the robot, tracker, calibration (path and digest), model
    and the conditions; ``time`` is added here (UTC).
    """
    verdict: verdicts.Verdict = result["verdict"]
    best = result["best"]
    if verdict.verdict == "ok":
        explanation: list = []
        text = ["the arm measures as its calibration predicts"]
    elif best is None:
        explanation = []
        text = [
            "no joint zero, base or reflector change (nor two of them) explains it: recalibrate"
        ]
    else:
        explanation = [best.to_json()]
        text = best.sentences()
    return {
        "format": FORMAT,
        "version": VERSION,
        "time": datetime.now(UTC).isoformat(timespec="seconds"),
        **info,
        "frame": "tracker",
        **verdict.to_json(),
        "pose_errors_mm": [float(np.linalg.norm(e)) for e in result["errors"]],
        "poses": [
            {
                "pose": int(p),
                "q_rad": q[i].tolist(),
                "measured_mm": points[i].tolist(),
                "predicted_mm": result["predicted"][i].tolist(),
                "error_mm": result["errors"][i].tolist(),
                "distance_mm": float(np.linalg.norm(result["errors"][i])),
                "predicted_rms_mm": float(result["sd"][i]),
            }
            for i, p in enumerate(poses)
        ],
        "explanation": explanation,
        "explanation_text": text,
        "candidates_tried": [f.to_json() for f in result["tried"]],
    }


def write(output: Path, doc: dict, table: pa.Table, meta: SessionMeta, inputs: list[Path]) -> None:
    """Write check.json and the check's session (``table``, ``meta``) beside it, both or neither."""
    from calibrator import session

    try:
        with outputs.Outputs(inputs=inputs) as batch:
            batch.text(output, json.dumps(doc, indent=2, allow_nan=False) + "\n")
            session.write(data_path(output), table, meta, batch)
    except ValueError as exc:
        raise CalibrationError(f"cannot write {output}: {exc}") from None
