"""The refusals of the input checks: both :class:`~calibrator.errors.CalibrationError`.

The CLI turns each into one line on stderr and exit code 2.
"""

from __future__ import annotations

from calibrator.errors import CalibrationError

__all__ = ["ConsistencyError", "StrictError"]


class StrictError(CalibrationError, ValueError):
    """An input that does not follow the strict grammar or exceeds its budget."""


class ConsistencyError(CalibrationError):
    """Two parts of the inputs that must agree do not."""
