"""The history's tables (SQLAlchemy Core), as of the newest migration.

One row a record: robots and trackers (who), sessions, calibrations,
verifications (pose and path tests), checks and circle checks (what
happened, when). Times are naive UTC
datetimes; documents and per-pose values are JSON. The migrations in
:mod:`calibrator.history.migrations` build exactly these tables; a test
compares the two.
"""

from __future__ import annotations

from sqlalchemy import (
    JSON,
    Boolean,
    Column,
    Date,
    DateTime,
    Float,
    ForeignKey,
    Index,
    Integer,
    MetaData,
    String,
    Table,
    Text,
)

metadata = MetaData()

#: A robot: its name is how every command and record refers to it (a
#: device id such as ``ur://10.0.0.5:ur5e`` unless the user names it).
robots = Table(
    "robots",
    metadata,
    Column("id", Integer, primary_key=True),
    Column("name", String(200), nullable=False, unique=True),
    Column("model", String(100)),
    Column("serial", String(100)),
    Column("description", Text),
)

#: A tracker: ``vendor:model:serial`` as it identifies itself.
trackers = Table(
    "trackers",
    metadata,
    Column("id", Integer, primary_key=True),
    Column("name", String(200), nullable=False, unique=True),
    Column("model", String(100)),
    Column("serial", String(100)),
    # Added by migration 0002: the date on the tracker's calibration certificate.
    Column("certificate_date", Date),
)

#: A measured session (a Parquet file): its digest identifies it.
sessions = Table(
    "sessions",
    metadata,
    Column("id", Integer, primary_key=True),
    Column("robot_id", ForeignKey("robots.id"), nullable=False),
    Column("tracker_id", ForeignKey("trackers.id")),
    Column("sha256", String(64), nullable=False, unique=True),
    Column("file", Text, nullable=False),
    Column("measured_at", DateTime, nullable=False),
    Column("model", String(100)),
    Column("poses", Integer, nullable=False),
    Column("conditions", JSON, nullable=False),
    # Added by migration 0003: the tool and tracker pose the footer declares
    # (``{"tool_id": ..., "tracker_pose": {"world", "tracker2world"}}``).
    Column("setup", JSON),
)

#: An identification (a calibration.json).
calibrations = Table(
    "calibrations",
    metadata,
    Column("id", Integer, primary_key=True),
    Column("robot_id", ForeignKey("robots.id"), nullable=False),
    Column("session_id", ForeignKey("sessions.id")),
    Column("sha256", String(64), nullable=False, unique=True),
    Column("file", Text),
    Column("created", DateTime, nullable=False),
    Column("model", String(100)),
    Column("session_sha256", String(64)),
    Column("held_out_rms_mm", Float),
    Column("predicted_mm", Float),
    Column("fit_rms_mm", Float),
    Column("parameters", JSON, nullable=False),
    Column("uncertainties", JSON, nullable=False),
    Column("statistics", JSON, nullable=False),
    Column("provenance", JSON, nullable=False),
    # Added by migration 0003: when its session was measured (NULL: not known).
    Column("measured_at", DateTime),
    Index("ix_calibrations_robot_created", "robot_id", "created"),
)

#: An ISO 9283 pose test (verify's JSON).
verifications = Table(
    "verifications",
    metadata,
    Column("id", Integer, primary_key=True),
    Column("robot_id", ForeignKey("robots.id"), nullable=False),
    Column("tracker_id", ForeignKey("trackers.id")),
    Column("sha256", String(64), nullable=False, unique=True),
    Column("file", Text),
    Column("measured_at", DateTime, nullable=False),
    Column("compensated", Boolean, nullable=False),
    Column("ap_mm", Float, nullable=False),
    Column("rp_mm", Float, nullable=False),
    Column("document", JSON, nullable=False),
)

#: An ISO 9283 path test (``verify --path``'s JSON; added by migration 0004).
path_verifications = Table(
    "path_verifications",
    metadata,
    Column("id", Integer, primary_key=True),
    Column("robot_id", ForeignKey("robots.id"), nullable=False),
    Column("tracker_id", ForeignKey("trackers.id")),
    Column("sha256", String(64), nullable=False, unique=True),
    Column("file", Text),
    Column("measured_at", DateTime, nullable=False),
    Column("compensated", Boolean, nullable=False),
    Column("shape", String(20), nullable=False),
    Column("speed_mm_s", Float, nullable=False),
    Column("at_p_mm", Float, nullable=False),
    Column("rt_p_mm", Float, nullable=False),
    Column("av_pct", Float, nullable=False),
    Column("rv_pct", Float, nullable=False),
    Column("fv_mm_s", Float, nullable=False),
    Column("document", JSON, nullable=False),
    # Added by migration 0005: the orientation figures (deg), NULL from a reflector.
    Column("ata_deg", Float),
    Column("atb_deg", Float),
    Column("atc_deg", Float),
    Column("rta_deg", Float),
    Column("rtb_deg", Float),
    Column("rtc_deg", Float),
)

#: A quick circle test (``calibrator check --circle``'s JSON; added by migration 0005).
circle_checks = Table(
    "circle_checks",
    metadata,
    Column("id", Integer, primary_key=True),
    Column("robot_id", ForeignKey("robots.id"), nullable=False),
    Column("tracker_id", ForeignKey("trackers.id")),
    Column("sha256", String(64), nullable=False, unique=True),
    Column("time", DateTime, nullable=False),
    Column("calibration_sha256", String(64), nullable=False),
    Column("compensated", Boolean, nullable=False),
    Column("speed_mm_s", Float, nullable=False),
    Column("radius_mm", Float, nullable=False),
    Column("radius_error_mm", Float, nullable=False),
    Column("out_of_roundness_mm", Float, nullable=False),
    Column("reversal_mm", Float, nullable=False),
    Column("centre_offset_mm", Float, nullable=False),
    Column("direction_gap_mm", Float),
    Column("verdict", String(20), nullable=False),
    Column("document", JSON, nullable=False),
)

#: A quick re-check (``calibrator check``'s JSON).
checks = Table(
    "checks",
    metadata,
    Column("id", Integer, primary_key=True),
    Column("robot_id", ForeignKey("robots.id"), nullable=False),
    Column("sha256", String(64), nullable=False, unique=True),
    Column("time", DateTime, nullable=False),
    Column("calibration_sha256", String(64), nullable=False),
    Column("verdict", String(20), nullable=False),
    Column("measured_mm", Float, nullable=False),
    Column("predicted_mm", Float, nullable=False),
    Column("pose_errors_mm", JSON, nullable=False),
    Column("explanation", JSON, nullable=False),
    Column("document", JSON, nullable=False),
)
