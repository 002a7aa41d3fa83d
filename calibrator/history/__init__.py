"""A per-robot history of sessions, calibrations, ISO 9283 tests and checks, in a database.

SQLite in one file by default, PostgreSQL for a team, through SQLAlchemy;
the schema is upgraded by the Alembic migrations shipped in
:mod:`calibrator.history.migrations`. See docs/history.md.

::

    with open_history("history.sqlite") as history:
        history.record_calibration("calibration.json")
        history.record_check(doc)            # calibrator check's JSON
        rows = history.calibrations("ur://10.0.0.5:ur5e")
"""

from calibrator.history.records import CHECK_FIELDS, VERDICTS, HistoryError
from calibrator.history.store import ENV_VAR, History, default_path, open_history

__all__ = [
    "CHECK_FIELDS",
    "ENV_VAR",
    "VERDICTS",
    "History",
    "HistoryError",
    "default_path",
    "open_history",
]
