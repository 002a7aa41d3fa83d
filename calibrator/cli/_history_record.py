"""Recording into ``--history`` from a command that wrote a file (identify, verify, check).

Apart from the ``history`` commands (:mod:`calibrator.cli.history`), which
read identify's options for ``history reidentify``: a command that records
imports this, not them.
"""

from __future__ import annotations

from pathlib import Path

import typer

from calibrator.cli._options import fail

__all__ = ["record", "refuse_unusable"]


def refuse_unusable(target: str) -> None:
    """Open and close ``--history`` before a command's work: one it cannot use is refused now.

    ``identify`` and ``verify`` record what they wrote at the end; a history
    that is no history, a server that does not answer or a bad URL is told
    in one line before anything is computed or written.
    """
    try:
        from calibrator.history.store import check_usable
    except ImportError:  # an installation without the history's database libraries
        fail("--history: this installation has no history support (calibrator.history)")
    check_usable(target)


def record(target: str, kind: str, path: Path) -> int:
    """Record a file a command just wrote (``identify``/``verify`` ``--history``); print it.

    Parameters
    ----------
    target : str
        ``--history`` as given.
    kind : {'calibration', 'verification'}
    path : Path
    """
    from calibrator.history import HistoryError, open_history

    try:
        with open_history(target) as history:
            method = {
                "calibration": history.record_calibration,
                "verification": history.record_verification,
            }[kind]
            number = method(path)
            typer.echo(f"recorded {kind} {number} in the history {history.where}")
    except HistoryError as exc:
        fail(
            f"wrote {path} but did not record it ({exc}); record it with: calibrator history import"
        )
    return number
