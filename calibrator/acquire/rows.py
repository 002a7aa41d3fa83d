"""One place that maps a measured pose to a journal record and records to session rows."""

from __future__ import annotations

from collections.abc import Iterable
from datetime import UTC, datetime
from typing import Any

import numpy as np
import pyarrow as pa
from numpy.typing import ArrayLike

from calibrator import session
from calibrator.acquire import ports
from calibrator.acquire.averaging import AveragedReading
from calibrator.robots import JointConvention


def measured_record(
    pose: int,
    q_rad: ArrayLike,
    avg: AveragedReading,
    attempts: int,
    conditions: dict | None = None,
) -> dict:
    """The journal record of a measured pose.

    Parameters
    ----------
    pose : int
        Plan row (0-based), the session's pose number.
    q_rad : array_like, shape (6,)
        Joint angles read back from the robot after the readings, rad.
    avg : AveragedReading
        Tracker frame, mm and rad.
    attempts : int
        Sets of readings taken (1 when nothing went wrong).
    conditions : dict, optional
        What the devices reported of the measuring conditions at the pose
        (:func:`conditions_of`); kept under ``"conditions"``.
    """
    record = {
        "pose": int(pose),
        "status": "measured",
        "q_rad": np.asarray(q_rad, float).tolist(),
        "point_mm": avg.mean_mm.tolist(),
        "std_mm": avg.std_mm.tolist(),
        "n_readings": int(avg.count),
        "rejected": int(avg.rejected),
        # Of those, the readings the robust rule set aside: a pose whose average needed it
        # is kept, but the record says so (a flagged reading is the tracker's own word).
        "outliers": int(avg.outliers),
        "attempts": int(attempts),
        "timestamp": datetime.now(UTC).isoformat(timespec="milliseconds"),
    }
    if avg.rotvec_mean_rad is not None:
        record["rotvec_rad"] = avg.rotvec_mean_rad.tolist()
    if conditions:
        record["conditions"] = conditions
    return record


def conditions_of(robot: Any, tracker: Any) -> dict:
    """What the robot and the tracker report of the measuring conditions now.

    The tracker's air (temperature degC, pressure hPa, humidity %RH), its time
    since power-on (s) and whether it says it is warmed up, with
    :data:`~calibrator.acquire.ports.REPORTS_CONDITIONS`; the joints'
    temperatures (degC, ``joint_temperatures_c``) with
    :data:`~calibrator.acquire.ports.REPORTS_TEMPERATURES`. A device that cannot
    say (or whose link fails on the query) adds nothing: the pose is measured
    all the same.
    """
    out: dict = {}
    if ports.REPORTS_CONDITIONS.offered_by(tracker):
        try:
            reported = tracker.conditions()
        except (ports.PortError, OSError):
            reported = None
        for key, value in (reported or {}).items():
            if key in CONDITION_KEYS and value is not None:
                out[key] = bool(value) if key == "warmed_up" else float(value)
    if ports.REPORTS_TEMPERATURES.offered_by(robot):
        try:
            temps = np.asarray(robot.joint_temperatures(), dtype=float).reshape(-1)
        except (ports.PortError, OSError, ValueError, RuntimeError):  # ur_rtde: RuntimeError
            temps = np.zeros(0)
        if temps.shape == (6,) and np.all(np.isfinite(temps)):
            out["joint_temperatures_c"] = temps.tolist()
    return out


#: The tracker's condition keys a record keeps.
CONDITION_KEYS = (
    "air_temperature_c",
    "air_pressure_hpa",
    "air_humidity_pct",
    "on_s",
    "warmed_up",
)


def summarise(records: Iterable[dict]) -> dict:
    """The conditions over the measured records (:func:`calibrator.session.conditions_summary`)."""
    measured = [r.get("conditions", {}) for r in records if r.get("status") == "measured"]
    return session.conditions_summary(session.condition_columns(measured))


def failed_record(pose: int, reason: str, attempts: int, causes: dict | None = None) -> dict:
    """The journal record of a pose given up after its retries.

    ``causes`` counts its lost readings by failure class (``{"beam broken": 4}``).
    """
    record = {"pose": int(pose), "status": "failed", "reason": reason, "attempts": int(attempts)}
    if causes:
        record["causes"] = {str(k): int(v) for k, v in causes.items()}
    return record


def to_table(records: Iterable[dict], convention: JointConvention) -> pa.Table:
    """Session rows (v1) from measured records, sorted by pose.

    Parameters
    ----------
    records : iterable of dict
        Records from :func:`measured_record` (failed ones are skipped); their
        joints are the model's angles.
    convention : calibrator.robots.JointConvention
        The arm's: the session's joint columns are the controller's angles.

    Returns
    -------
    pyarrow.Table
        ``pose``, ``q1_rad..q6_rad``, ``x_mm..z_mm``, ``sx_mm..sz_mm``,
        ``n_readings``, ``timestamp`` and, for a 6-DoF probe, ``rx_rad..rz_rad``.
    """
    rows = sorted((r for r in records if r["status"] == "measured"), key=lambda r: int(r["pose"]))
    if not rows:
        raise ValueError("no measured poses")
    rot = [r.get("rotvec_rad") for r in rows]
    table = session.to_table(
        convention.to_controller(np.array([r["q_rad"] for r in rows])),
        np.array([r["point_mm"] for r in rows]),
        rotvecs=np.array(rot) if all(v is not None for v in rot) else None,
        spread=np.array([r["std_mm"] for r in rows]),
        n_readings=np.array([r["n_readings"] for r in rows]),
        timestamps=pa.array([r["timestamp"] for r in rows], pa.string()),
        conditions=[r.get("conditions", {}) for r in rows],
    )
    # Pose numbers are plan rows, so a failed pose leaves a visible gap.
    poses = pa.array([int(r["pose"]) for r in rows], pa.int64())
    return table.set_column(table.column_names.index("pose"), "pose", poses)
