"""A forked helper that runs a study's blocks on the core a starting cluster leaves idle.

Starting a local Dask cluster is mostly importing Dask, a fifth of a second
of one core. With ``--workers 2`` or more the user gave the run a second
core, and it would idle meanwhile. So the calling process forks one helper
before anything else and imports Dask at once. The helper runs block 0,
sends the study's grid (whose ranges come from block 0), then runs blocks
from the end of the study downwards, claiming each under a lock it shares
with the caller. Once the cluster is up the caller closes the claims
(:meth:`Spare.stop`): the cluster runs every block between 1 and the
lowest one claimed, and the helper, after the block it is on, sends the
summary of its blocks through a pipe (:meth:`Spare.result`). Which process
ran a block does not change the result: summaries merge exactly
(:meth:`misalignment.Summary.merge`).

A helper that fails, or dies, sends nothing more; its blocks are then run
again (by the cluster, or block 0 and the grid by the caller if it never
sent them). It ignores Ctrl-C, which the caller handles and then kills it
(:meth:`Spare.close`). It never outlives the caller, however that ends (a
helper left running would hold the terminal's output open, and block for
ever on a pipe nobody reads): it is a daemon process, which Python ends at
exit; on Linux the kernel kills it when the caller dies; and it stops
between blocks once the caller is gone.
"""

from __future__ import annotations

import ctypes
import multiprocessing
import os
import signal
import sys
import threading
from typing import Any

from calibrator.analysis import misalignment as mc

#: How long :meth:`Spare.stop` waits for the claims' lock, which the helper
#: holds only to read and write two integers, before it takes the helper as hung.
LOCK_WAIT_S = 1.0


class Spare:
    """One forked process running block 0, then blocks ``low..n_blocks-1`` highest first.

    Parameters
    ----------
    study : misalignment.Study
    low : int
        Lowest block the helper may claim after block 0 (>= 1; the cluster
        gets those below).

    Notes
    -----
    Fork before this process starts threads of its own (before Dask is
    imported): only the forking thread exists in the child.
    """

    def __init__(self, study: mc.Study, low: int) -> None:
        ctx = multiprocessing.get_context("fork")
        # claims[0]: the lowest block claimed so far (the helper's next is one
        # below); claims[1]: the lowest it may claim, raised to claims[0] to stop it.
        self._claims: Any = ctx.RawArray("q", [study.n_blocks, low])
        self._lock = ctx.Lock()
        self._results, sender = ctx.Pipe(duplex=False)
        self._process = ctx.Process(
            target=_work,
            args=(study, self._claims, self._lock, sender, self._results, os.getpid()),
            name="calibrator-spare",
            daemon=True,
        )
        _start_deferring_ctrl_c(self._process)
        sender.close()  # the child's copy is the one that sends
        self._failed = False

    def stop(self) -> int:
        """Let the helper claim no more blocks; the lowest it claimed (``n_blocks`` if none).

        The helper's blocks are block 0 and that one up to the last; it may
        still be running one of them.
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

    def grid(self) -> mc.Grid | None:
        """The study's grid, from the helper's block 0; None if it failed before sending it.

        Waits for block 0 if the helper is still on it. Call before :meth:`result`.
        """
        grid = self._receive()
        return grid if isinstance(grid, mc.Grid) else None

    def result(self) -> mc.Summary | None:
        """The summary of the helper's blocks, once it has run them; None if it failed.

        Call after :meth:`stop` and :meth:`grid`. Ends the helper.
        """
        summary = None if self._failed else self._receive()
        self.close()
        return summary if isinstance(summary, mc.Summary) else None

    def _receive(self) -> Any:
        try:
            return self._results.recv()
        except (EOFError, OSError):  # it died without sending, or was ended
            return None

    def close(self) -> None:
        """End the helper, whatever it is doing (idempotent)."""
        self._end()
        self._results.close()

    def _end(self) -> None:
        if self._process.is_alive():
            self._process.kill()
        self._process.join()


def _work(study: mc.Study, claims: Any, lock: Any, sender: Any, receiver: Any, caller: int) -> None:
    """The helper: block 0 and the grid, then blocks claimed from the top; send the summary.

    ``receiver`` is the caller's end of the pipe, inherited with the fork and
    closed here: with only the caller holding it, a send to a caller that died
    fails instead of waiting for a reader. ``caller`` is the caller's pid.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the caller handles Ctrl-C and kills us
    _die_with(caller)
    receiver.close()
    try:
        grid, summary = mc.first_block(study)
    except BaseException:  # noqa: BLE001 - the caller makes the grid itself
        _send_last(sender, None)
        return
    if not _send(sender, grid):
        return
    try:
        while True:
            if os.getppid() != caller:  # orphaned: nobody will read what we send
                os._exit(1)
            with lock:
                k = claims[0] - 1
                if k < claims[1]:
                    break
                claims[0] = k
            summary.add_block(k, *mc.simulate_block(study, k), grid)
        outcome: mc.Summary | None = summary
    except BaseException:  # noqa: BLE001 - any failure: the caller reruns our blocks
        outcome = None
    _send_last(sender, outcome)


def _start_deferring_ctrl_c(process: Any) -> None:
    """Start (fork) ``process``, holding a Ctrl-C that comes meanwhile until it is done.

    A KeyboardInterrupt raised in one of Python's at-fork handlers is
    swallowed ("Exception ignored") and leaves that handler's lock held:
    logging's, which Dask's import then waited on for ever (seen in about
    one Ctrl-C in 50 sent as a run began). Only the main thread gets
    KeyboardInterrupt, and only it can change the handler.
    """
    previous = signal.getsignal(signal.SIGINT)
    if threading.current_thread() is not threading.main_thread() or not callable(previous):
        process.start()  # SIGINT ignored, or left at the OS default: nothing to hold
        return
    held: list[int] = []
    signal.signal(signal.SIGINT, lambda signum, frame: held.append(signum))
    try:
        process.start()
    finally:
        signal.signal(signal.SIGINT, previous)
    if held:
        previous(signal.SIGINT, None)  # KeyboardInterrupt, or the caller's own handler


#: Linux ``prctl`` option: the signal this process gets when its parent dies.
PR_SET_PDEATHSIG = 1


def _die_with(caller: int) -> None:
    """Have the kernel kill this process when ``caller`` (its parent) dies (Linux only)."""
    if sys.platform.startswith("linux"):
        try:
            ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
        except (OSError, AttributeError):  # another C library: the checks between blocks remain
            pass
    if os.getppid() != caller:  # it died before the line above took effect
        os._exit(1)


def _send(sender: Any, message: Any) -> bool:
    """Send ``message`` to the caller; False, quietly, if the caller is gone."""
    try:
        sender.send(message)
    except OSError:  # the caller closed its end, or died: nobody reads
        return False
    return True


def _send_last(sender: Any, message: Any) -> None:
    _send(sender, message)
    sender.close()
