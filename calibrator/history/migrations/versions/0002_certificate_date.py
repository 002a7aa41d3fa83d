"""Trackers gain their certificate date; calibrations an index by robot and time.

Revision ID: 0002
Revises: 0001
"""

import sqlalchemy as sa
from alembic import op

revision = "0002"
down_revision = "0001"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.add_column("trackers", sa.Column("certificate_date", sa.Date))
    op.create_index("ix_calibrations_robot_created", "calibrations", ["robot_id", "created"])


def downgrade() -> None:
    op.drop_index("ix_calibrations_robot_created", "calibrations")
    op.drop_column("trackers", "certificate_date")
