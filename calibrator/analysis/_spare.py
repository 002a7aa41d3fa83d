"""A forked helper that runs a study's blocks on the core a starting cluster leaves idle.

Starting a local Dask cluster is mostly importing Dask, a fifth of a second
of one core. With ``--workers 2`` or more the user gave the run a second
core, and it would idle meanwhile. So before it imports Dask the calling
process forks one helper, which runs blocks from the end of the study
downwards, claiming each under a lock it shares with the caller. Once the
cluster is up the caller closes the claims (:meth:`Spare.stop`): the cluster
runs every block below the lowest one claimed, and the helper, after the
block it is on, sends the summary of its blocks through a pipe
(:meth:`Spare.result`). Which process ran a block does not change the
result: summaries merge exactly (:meth:`misalignment.Summary.merge`).

A helper that fails, or dies, sends nothing; its blocks are then run again
by the cluster. It ignores Ctrl-C, which the caller handles and then kills
it (:meth:`Spare.close`).
"""

from __future__ import annotations

import multiprocessing
import signal
from typing import Any

from calibrator.analysis import _malloc
from calibrator.analysis import misalignment as mc

#: How long :meth:`Spare.stop` waits for the claims' lock, which the helper
#: holds only to read and write two integers, before it takes the helper as hung.
LOCK_WAIT_S = 1.0


class Spare:
    """One forked process running blocks ``low..n_blocks-1`` of a study, highest first.

    Parameters
    ----------
    study : misalignment.Study
    grid : misalignment.Grid
    low : int
        Lowest block the helper may run (the caller keeps those below).

    Notes
    -----
    Fork before this process starts threads of its own (before Dask is
    imported): only the forking thread exists in the child.
    """

    def __init__(self, study: mc.Study, grid: mc.Grid, low: int) -> None:
        ctx = multiprocessing.get_context("fork")
        # claims[0]: the lowest block claimed so far (the helper's next is one
        # below); claims[1]: the lowest it may claim, raised to claims[0] to stop it.
        self._claims: Any = ctx.RawArray("q", [study.n_blocks, low])
        self._lock = ctx.Lock()
        self._results, sender = ctx.Pipe(duplex=False)
        self._process = ctx.Process(
            target=_work,
            args=(study, grid, self._claims, self._lock, sender),
            name="calibrator-spare",
        )
        self._process.start()
        sender.close()  # the child's copy is the one that sends
        self._failed = False

    def stop(self) -> int:
        """Let the helper claim no more blocks; the lowest it claimed (``n_blocks`` if none).

        The helper's blocks are that one up to the last; it may still be
        running one of them.
        """
        if not self._lock.acquire(timeout=LOCK_WAIT_S):
            # Hung, or killed while holding the lock: ended, it claims no more,
            # and nothing it sent counts.
            self._failed = True
            self._end()
            return int(self._claims[0])
        try:
            self._claims[1] = self._claims[0]
            return int(self._claims[0])
        finally:
            self._lock.release()

    def result(self) -> mc.Summary | None:
        """The summary of the helper's blocks, once it has run them; None if it failed.

        Call after :meth:`stop`. Ends the helper.
        """
        summary = None
        if not self._failed:
            try:
                summary = self._results.recv()
            except (EOFError, OSError):  # died without sending
                summary = None
        self.close()
        return summary if isinstance(summary, mc.Summary) else None

    def close(self) -> None:
        """End the helper, whatever it is doing (idempotent)."""
        self._end()
        self._results.close()

    def _end(self) -> None:
        if self._process.is_alive():
            self._process.kill()
        self._process.join()


def _work(study: mc.Study, grid: mc.Grid, claims: Any, lock: Any, sender: Any) -> None:
    """The helper: claim the next block down, run it, until the claims close; send the summary."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the caller handles Ctrl-C and kills us
    summary = mc.Summary()
    try:
        _malloc.keep_freed_memory()
        while True:
            with lock:
                k = claims[0] - 1
                if k < claims[1]:
                    break
                claims[0] = k
            summary.add_block(k, *mc.simulate_block(study, k), grid)
        outcome: mc.Summary | None = summary
    except BaseException:  # noqa: BLE001 - any failure: the caller reruns our blocks
        outcome = None
    try:
        sender.send(outcome)
    finally:
        sender.close()
