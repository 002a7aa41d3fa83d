"""Path tests keep their orientation figures; the quick circle test gets its own table.

``path_verifications`` gains ISO 9283 clause 7's orientation figures
``ata_deg``..``rtc_deg`` (degrees): a 6-DoF probe's path test gives them, a
reflector's leaves them NULL (path tests recorded before keep NULL: their
documents carry none).

``circle_checks``: one row a ``calibrator check --circle`` run, with what a
trend reads of it (radius error, out-of-roundness, the largest reversal mark,
centre offset, direction gap, all mm; the speed, mm/s; the verdict) and the
whole document as the check wrote it.

Revision ID: 0005
Revises: 0004
"""

import sqlalchemy as sa
from alembic import op

revision = "0005"
down_revision = "0004"
branch_labels = None
depends_on = None

#: The orientation figures' columns (degrees), in the table's order.
ORIENTATION = ("ata_deg", "atb_deg", "atc_deg", "rta_deg", "rtb_deg", "rtc_deg")


def upgrade() -> None:
    with op.batch_alter_table("path_verifications") as batch:
        for name in ORIENTATION:
            batch.add_column(sa.Column(name, sa.Float))
    op.create_table(
        "circle_checks",
        sa.Column("id", sa.Integer, primary_key=True),
        sa.Column("robot_id", sa.Integer, sa.ForeignKey("robots.id"), nullable=False),
        sa.Column("tracker_id", sa.Integer, sa.ForeignKey("trackers.id")),
        sa.Column("sha256", sa.String(64), nullable=False, unique=True),
        sa.Column("time", sa.DateTime, nullable=False),
        sa.Column("calibration_sha256", sa.String(64), nullable=False),
        sa.Column("compensated", sa.Boolean, nullable=False),
        sa.Column("speed_mm_s", sa.Float, nullable=False),
        sa.Column("radius_mm", sa.Float, nullable=False),
        sa.Column("radius_error_mm", sa.Float, nullable=False),
        sa.Column("out_of_roundness_mm", sa.Float, nullable=False),
        sa.Column("reversal_mm", sa.Float, nullable=False),
        sa.Column("centre_offset_mm", sa.Float, nullable=False),
        sa.Column("direction_gap_mm", sa.Float),
        sa.Column("verdict", sa.String(20), nullable=False),
        sa.Column("document", sa.JSON, nullable=False),
    )


def downgrade() -> None:
    op.drop_table("circle_checks")
    with op.batch_alter_table("path_verifications") as batch:
        for name in reversed(ORIENTATION):
            batch.drop_column(name)
