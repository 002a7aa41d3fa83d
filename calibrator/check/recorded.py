"""A check of a recorded session: poses measured earlier, or by another tool, judged as a check.

``calibrator check --session FILE`` reads a session file (this project's
format, docs/session-format.md) in the tracker frame, and gives the verdict,
explanation and document a measured check gives (:mod:`.document`); the
document's ``measured_at`` is when the session was measured (its first
pose's ``timestamp``, else its footer's ``measured_at``), which the history
files it under.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from calibrator.check import document as documents
from calibrator.check.model import Calibrated
from calibrator.errors import CalibrationError

#: Per-axis spread columns of a session (mm) and its readings per pose.
_SPREAD = ("sx_mm", "sy_mm", "sz_mm")
_COUNT = "n_readings"


@dataclass(frozen=True)
class Recorded:
    """A session's poses as a check reads them.

    Attributes
    ----------
    poses : list of int
        The session's pose numbers.
    q : ndarray, shape (N, 6)
        Joint angles, rad.
    points : ndarray, shape (N, 3)
        Measured probe points, tracker frame, mm.
    stderr : ndarray, shape (N, 3) or None
        Standard error of each averaged point per axis (spread over the root
        of the readings), mm; None when the session records no spread.
    robot, tracker : str or None
        As the footer names them (``measured``), or the simulated arm's name.
    measured_at : str or None
        ISO 8601 UTC time of the first pose.
    model : str or None
    """

    poses: list[int]
    q: np.ndarray
    points: np.ndarray
    stderr: np.ndarray | None
    robot: str | None
    tracker: str | None
    measured_at: str | None
    model: str | None


def read(path: Path) -> Recorded:
    """Read a session file for a check.

    Raises
    ------
    CalibrationError
        Not a session, not in the tracker frame, or fewer than 2 poses.
    """
    from calibrator import session as sessions
    from calibrator.history.records import HistoryError, measured_time
    from calibrator.inputs import session_table

    loaded = sessions.load(path)
    if loaded.meta.frame != "tracker":
        raise CalibrationError(
            f"{path}: its points are in the {loaded.meta.frame} frame; a check compares "
            "tracker readings (a session in the tracker frame)"
        )
    obs = loaded.observations
    if len(obs.q) < 2:
        raise CalibrationError(f"{path}: {len(obs.q)} pose(s): a check needs at least 2")
    table = loaded.table
    stderr = None
    if all(c in table.column_names for c in _SPREAD):
        spread = loaded.array(_SPREAD)
        count = (
            np.maximum(session_table.floats(table, _COUNT), 1.0)
            if _COUNT in table.column_names
            else np.ones(len(spread))
        )
        stderr = spread / np.sqrt(count)[:, None]
        if not np.all(np.isfinite(stderr)):
            stderr = None
    poses = (
        [int(p) for p in table.column("pose").to_pylist()]
        if "pose" in table.column_names
        else list(range(len(obs.q)))
    )
    extra = loaded.meta.extra
    measured = extra.get("measured") if isinstance(extra.get("measured"), dict) else {}
    robot = measured.get("robot") if isinstance(measured, dict) else None
    simulated = extra.get("simulated")
    if not robot and isinstance(simulated, dict) and loaded.meta.model:
        robot = f"sim:{loaded.meta.model}:seed={simulated.get('seed')}"
    tracker = measured.get("tracker") if isinstance(measured, dict) else None
    try:
        when = measured_time(table, extra, str(path))
    except HistoryError as exc:
        raise CalibrationError(str(exc)) from None
    return Recorded(
        poses,
        np.asarray(obs.q, float),
        np.asarray(obs.points, float),
        stderr,
        str(robot) if robot else None,
        str(tracker) if tracker else None,
        None if when is None else when.isoformat() + "Z",
        loaded.meta.model,
    )


def check(model: Calibrated, recorded: Recorded, tolerance_mm: float | None, info: dict) -> dict:
    """The check document of a recorded session (as :func:`.document.document`).

    ``info`` names the calibration (path, digest), the model and the session
    (``data``); the robot, tracker and ``measured_at`` come from the session.
    """
    result = documents.evaluate(model, recorded.q, recorded.points, recorded.stderr, tolerance_mm)
    full = {
        "robot": recorded.robot,
        "tracker": recorded.tracker,
        "measured_at": recorded.measured_at,
        **info,
    }
    from calibrator import robots

    # The document states joints as the controller does (recorded.q are the model's).
    shown = robots.convention_of(recorded.model).to_controller(recorded.q)
    return documents.document(result, recorded.poses, shown, recorded.points, info=full)
