"""The one size and time budget check: refused above the limit, before any work starts.

An option that allocates or waits (``--trials``, ``--timeout``) is checked
here before anything is allocated or waited for, so a typo (``1e12``)
costs a one-line message, not an hour or the machine's memory.

Use::

    from calibrator.inputs import budgets

    budgets.check_budget("--trials", 10**12, 10**9, "trials")   # StrictError
"""

from __future__ import annotations

from calibrator.inputs.errors import StrictError
from calibrator.inputs.messages import amount

__all__ = ["check_budget"]


def check_budget(what: str, value: float, limit: float, unit: str = "") -> None:
    """Refuse a size or a time above its budget, before anything is allocated or waited for.

    Parameters
    ----------
    what : str
        The option or input (``"--trials"``).
    value, limit : number
        ``value`` must be <= ``limit`` (and not NaN).
    unit : str
        Unit of both, named in the error (``"trials"``, ``"s"``).

    Raises
    ------
    StrictError
        ``--trials: 1000000000000 trials is more than the limit of 1e+09 trials``.
    """
    if not value <= limit:
        unit = f" {unit}" if unit else ""
        where = f"{what}: " if what else ""
        raise StrictError(
            f"{where}{amount(value)}{unit} is more than the limit of {amount(limit)}{unit}"
        )
