"""Alembic migrations of the history, shipped in the package.

:func:`upgrade` brings a database to :data:`HEAD` inside the caller's
transaction, so an installed copy upgrades a history without an
``alembic.ini``. Revisions live in ``versions/``, one file each.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

#: The newest revision (checked against the scripts by a test).
HEAD = "0005"
#: Every revision, oldest first.
REVISIONS = ("0001", "0002", "0003", "0004", "0005")

_HERE = Path(__file__).parent


def config(connection: Any = None) -> Any:
    """An Alembic ``Config`` for the shipped scripts, run on ``connection``."""
    from alembic.config import Config

    cfg = Config()
    cfg.set_main_option("script_location", str(_HERE))
    cfg.attributes["connection"] = connection
    return cfg


def current(connection: Any) -> str | None:
    """The revision a database is at (``None``: empty, no history yet)."""
    from alembic.runtime.migration import MigrationContext

    return MigrationContext.configure(connection).get_current_revision()


def upgrade(connection: Any, revision: str = "head") -> None:
    """Run the migrations up to ``revision`` on ``connection`` (in its transaction)."""
    from alembic import command

    command.upgrade(config(connection), revision)
