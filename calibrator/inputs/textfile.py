"""A user's text file read whole, within its size budget, as UTF-8."""

from __future__ import annotations

from pathlib import Path

from calibrator.inputs.errors import StrictError

__all__ = ["read_text"]


def read_text(path: str | Path, max_bytes: int, what: str = "a text file") -> str:
    """The UTF-8 text of a file no larger than ``max_bytes``.

    ``what`` names the kind of file in the errors (``"a UR calibration file"``).

    Raises
    ------
    StrictError
        Missing, too large, not a file or not UTF-8.
    """
    path = Path(path)
    if not path.is_file():
        raise StrictError(f"{path}: no such file")
    size = path.stat().st_size
    if size > max_bytes:
        raise StrictError(f"{path}: {size} bytes is too large for {what} (at most {max_bytes})")
    try:
        return path.read_bytes().decode("utf-8")
    except UnicodeDecodeError:
        raise StrictError(f"{path}: not {what} (not UTF-8 text)") from None
