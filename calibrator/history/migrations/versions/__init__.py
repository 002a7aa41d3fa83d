"""Revisions of the history's schema, one a file (Alembic loads them)."""
