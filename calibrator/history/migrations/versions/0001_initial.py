"""The first schema: robots, trackers, sessions, calibrations, verifications, checks.

Revision ID: 0001
Revises:
"""

import sqlalchemy as sa
from alembic import op

revision = "0001"
down_revision = None
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "robots",
        sa.Column("id", sa.Integer, primary_key=True),
        sa.Column("name", sa.String(200), nullable=False, unique=True),
        sa.Column("model", sa.String(100)),
        sa.Column("serial", sa.String(100)),
        sa.Column("description", sa.Text),
    )
    op.create_table(
        "trackers",
        sa.Column("id", sa.Integer, primary_key=True),
        sa.Column("name", sa.String(200), nullable=False, unique=True),
        sa.Column("model", sa.String(100)),
        sa.Column("serial", sa.String(100)),
    )
    op.create_table(
        "sessions",
        sa.Column("id", sa.Integer, primary_key=True),
        sa.Column("robot_id", sa.Integer, sa.ForeignKey("robots.id"), nullable=False),
        sa.Column("tracker_id", sa.Integer, sa.ForeignKey("trackers.id")),
        sa.Column("sha256", sa.String(64), nullable=False, unique=True),
        sa.Column("file", sa.Text, nullable=False),
        sa.Column("measured_at", sa.DateTime, nullable=False),
        sa.Column("model", sa.String(100)),
        sa.Column("poses", sa.Integer, nullable=False),
        sa.Column("conditions", sa.JSON, nullable=False),
    )
    op.create_table(
        "calibrations",
        sa.Column("id", sa.Integer, primary_key=True),
        sa.Column("robot_id", sa.Integer, sa.ForeignKey("robots.id"), nullable=False),
        sa.Column("session_id", sa.Integer, sa.ForeignKey("sessions.id")),
        sa.Column("sha256", sa.String(64), nullable=False, unique=True),
        sa.Column("file", sa.Text),
        sa.Column("created", sa.DateTime, nullable=False),
        sa.Column("model", sa.String(100)),
        sa.Column("session_sha256", sa.String(64)),
        sa.Column("held_out_rms_mm", sa.Float),
        sa.Column("predicted_mm", sa.Float),
        sa.Column("fit_rms_mm", sa.Float),
        sa.Column("parameters", sa.JSON, nullable=False),
        sa.Column("uncertainties", sa.JSON, nullable=False),
        sa.Column("statistics", sa.JSON, nullable=False),
        sa.Column("provenance", sa.JSON, nullable=False),
    )
    op.create_table(
        "verifications",
        sa.Column("id", sa.Integer, primary_key=True),
        sa.Column("robot_id", sa.Integer, sa.ForeignKey("robots.id"), nullable=False),
        sa.Column("tracker_id", sa.Integer, sa.ForeignKey("trackers.id")),
        sa.Column("sha256", sa.String(64), nullable=False, unique=True),
        sa.Column("file", sa.Text),
        sa.Column("measured_at", sa.DateTime, nullable=False),
        sa.Column("compensated", sa.Boolean, nullable=False),
        sa.Column("ap_mm", sa.Float, nullable=False),
        sa.Column("rp_mm", sa.Float, nullable=False),
        sa.Column("document", sa.JSON, nullable=False),
    )
    op.create_table(
        "checks",
        sa.Column("id", sa.Integer, primary_key=True),
        sa.Column("robot_id", sa.Integer, sa.ForeignKey("robots.id"), nullable=False),
        sa.Column("sha256", sa.String(64), nullable=False, unique=True),
        sa.Column("time", sa.DateTime, nullable=False),
        sa.Column("calibration_sha256", sa.String(64), nullable=False),
        sa.Column("verdict", sa.String(20), nullable=False),
        sa.Column("measured_mm", sa.Float, nullable=False),
        sa.Column("predicted_mm", sa.Float, nullable=False),
        sa.Column("pose_errors_mm", sa.JSON, nullable=False),
        sa.Column("explanation", sa.JSON, nullable=False),
        sa.Column("document", sa.JSON, nullable=False),
    )


def downgrade() -> None:
    for table in ("checks", "verifications", "calibrations", "sessions", "trackers", "robots"):
        op.drop_table(table)
