"""ISO 9283 path tests (``verify --path``) get their own table.

``path_verifications``: one row a path test, with its shape, speed and the
clause 7 figures a trend reads (AT_P, RT_P, AV, RV, FV); the whole document
as verify wrote it. The pose tests' table keeps its NOT NULL AP and RP, which a
path test does not have.

Revision ID: 0004
Revises: 0003
"""

import sqlalchemy as sa
from alembic import op

revision = "0004"
down_revision = "0003"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "path_verifications",
        sa.Column("id", sa.Integer, primary_key=True),
        sa.Column("robot_id", sa.Integer, sa.ForeignKey("robots.id"), nullable=False),
        sa.Column("tracker_id", sa.Integer, sa.ForeignKey("trackers.id")),
        sa.Column("sha256", sa.String(64), nullable=False, unique=True),
        sa.Column("file", sa.Text),
        sa.Column("measured_at", sa.DateTime, nullable=False),
        sa.Column("compensated", sa.Boolean, nullable=False),
        sa.Column("shape", sa.String(20), nullable=False),
        sa.Column("speed_mm_s", sa.Float, nullable=False),
        sa.Column("at_p_mm", sa.Float, nullable=False),
        sa.Column("rt_p_mm", sa.Float, nullable=False),
        sa.Column("av_pct", sa.Float, nullable=False),
        sa.Column("rv_pct", sa.Float, nullable=False),
        sa.Column("fv_mm_s", sa.Float, nullable=False),
        sa.Column("document", sa.JSON, nullable=False),
    )


def downgrade() -> None:
    op.drop_table("path_verifications")
