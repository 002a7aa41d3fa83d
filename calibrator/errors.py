"""The domain's one exception tree.

The CLI turns every :class:`CalibrationError` into one line on stderr and
exit code 2.
"""


class CalibrationError(Exception):
    """Base of every error the domain reports to a user."""


class SessionError(CalibrationError, ValueError):
    """A session file is missing, unreadable or does not follow the schema."""


class IdentifiabilityError(CalibrationError):
    """The data cannot identify what was asked (too few poses, degenerate poses)."""
