"""Progress of a measure run: a one-line bar on a terminal, plain lines otherwise."""

from __future__ import annotations

import time

import numpy as np


class Reporter:
    """Reports pose i/N, ETA and the last spread after each pose.

    Parameters
    ----------
    total : int
        Poses in the plan.
    stream : text file
        Where to write (a terminal gets a bar redrawn in place).
    """

    def __init__(self, total: int, stream):
        self.total = total
        self.stream = stream
        self.tty = stream.isatty()
        self._t0 = time.monotonic()
        self._first_done = None

    def update(self, progress) -> None:
        """Called by the loop with a :class:`calibrator.acquire.loop.Progress`."""
        now = time.monotonic()
        if self._first_done is None:
            self._first_done = (progress.done - 1, self._t0)
        done0, t0 = self._first_done
        rate = (progress.done - done0) / max(now - t0, 1e-9)
        eta = (self.total - progress.done) / rate if rate > 0 else float("nan")
        record = progress.record
        if record["status"] == "measured":
            spread = float(np.linalg.norm(record["std_mm"]) * 1000.0)
            what = f"spread {spread:.1f} um"
        else:
            what = "FAILED"
        line = f"pose {progress.done}/{self.total} (#{progress.pose}) {what} ETA {eta:.0f} s"
        if self.tty:
            width = 20
            filled = int(width * progress.done / max(self.total, 1))
            self.stream.write(f"\r[{'#' * filled}{'.' * (width - filled)}] {line}   ")
        else:
            self.stream.write(line + "\n")
        self.stream.flush()

    def finish(self) -> None:
        if self.tty:
            self.stream.write("\n")
            self.stream.flush()
