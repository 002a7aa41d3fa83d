"""Calibrations carry when their session was measured; sessions what they declare of their set-up.

``calibrations.measured_at``: the time of the calibration's session (its
first pose), filled here from the sessions already recorded; a calibration
whose session the history does not hold keeps NULL (read as its
``created``). ``sessions.setup``: the tool and the tracker's pose in a world
frame the session's footer declares (``tool_id``, ``tracker_pose``), which
decide whether two calibrations may compare their tool and base.

Revision ID: 0003
Revises: 0002
"""

import sqlalchemy as sa
from alembic import op

revision = "0003"
down_revision = "0002"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("calibrations") as batch:
        batch.add_column(sa.Column("measured_at", sa.DateTime))
    with op.batch_alter_table("sessions") as batch:
        batch.add_column(sa.Column("setup", sa.JSON))
    op.execute(
        "UPDATE calibrations SET measured_at = "
        "(SELECT sessions.measured_at FROM sessions WHERE sessions.id = calibrations.session_id)"
    )


def downgrade() -> None:
    with op.batch_alter_table("sessions") as batch:
        batch.drop_column("setup")
    with op.batch_alter_table("calibrations") as batch:
        batch.drop_column("measured_at")
