"""Alembic's environment: migrations run on the connection the caller opened."""

from alembic import context

connection = context.config.attributes.get("connection")
if connection is None:
    raise RuntimeError("the history's migrations run through calibrator.history only")
context.configure(connection=connection, transactional_ddl=True)
# The caller's transaction holds the upgrade: all of it lands, or none.
context.run_migrations()
