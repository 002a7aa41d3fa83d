"""Running a Monte Carlo study's chunks: in-process, on a LocalCluster, or on a cluster.

Dask does the scheduling (``dask.distributed``); this module only cuts a
study into chunks of whole blocks and folds the chunks' summaries together.
Dask is imported only when a cluster is asked for.
"""

from __future__ import annotations

import logging
import os
import threading
from collections.abc import Callable, Iterator
from concurrent.futures import CancelledError, Future
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

from calibrator.analysis import misalignment as mc
from calibrator.errors import CalibrationError


def chunks(n_blocks: int, blocks_per_chunk: int, first: int = 0) -> list[list[int]]:
    """Consecutive runs of block indices ``first..n_blocks-1``, ``blocks_per_chunk`` at a time."""
    step = max(1, int(blocks_per_chunk))
    return [list(range(i, min(i + step, n_blocks))) for i in range(first, n_blocks, step)]


def even_chunks(n_blocks: int, count: int, first: int = 0) -> list[list[int]]:
    """Blocks ``first..n_blocks-1`` as ``count`` consecutive runs whose sizes differ by at most one.

    Workers that finish together waste no core at the end; fewer runs when
    there are fewer blocks.
    """
    n = max(0, n_blocks - first)
    count = min(max(1, int(count)), n) if n else 0
    bounds = [first + (n * i) // count for i in range(count + 1)] if count else []
    return [list(range(a, b)) for a, b in zip(bounds, bounds[1:], strict=False)]


def default_blocks_per_chunk(n_blocks: int, workers: int) -> int:
    """Enough chunks to keep ``workers`` busy and balanced (about 4 each), at most 50 blocks."""
    return max(1, min(50, -(-n_blocks // (4 * max(1, workers)))))


def run(
    study: mc.Study,
    *,
    chunk_trials: int | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> tuple[mc.Summary, mc.Grid]:
    """Run a study and return its merged :class:`~calibrator.analysis.misalignment.Summary`.

    Parameters
    ----------
    study : Study
    chunk_trials : int, optional
        Trials per chunk (rounded up to whole blocks of
        :data:`~calibrator.analysis.misalignment.BLOCK`); the result does not
        depend on it.
    workers : int, optional
        Start a Dask ``LocalCluster`` of this many single-threaded worker processes.
    scheduler : str, optional
        Address of an existing Dask scheduler (``tcp://host:8786``); its
        workers need this package installed.
    progress : callable, optional
        Called as ``progress(trials_done, trials_total)`` after each chunk.

    Returns
    -------
    summary : Summary
    grid : Grid
    """
    if workers is not None and scheduler is not None:
        raise CalibrationError("give --workers or --scheduler, not both")
    if workers is not None and not 1 <= workers <= (os.cpu_count() or 1):
        # More local workers than cores only adds processes and memory, never speed.
        raise CalibrationError(
            f"--workers must be in [1, {os.cpu_count() or 1}] (this machine's cores), got {workers}"
        )
    if chunk_trials is not None and chunk_trials < 1:
        raise CalibrationError(f"--chunk must be >= 1 trial, got {chunk_trials}")
    if workers is None and scheduler is None:
        grid, fold = _first_block(study, progress)
        per_chunk = _blocks_per_chunk(study, chunk_trials, 1)
        _run_here(fold, grid, chunks(study.n_blocks, per_chunk, first=1))
        return fold.total, grid
    if scheduler is None and workers is not None and workers >= 2 and study.n_blocks > 2:
        # (With two blocks or fewer, block 0 leaves a helper at most one.)
        return _run_with_spare(study, chunk_trials, workers, progress)
    # Starting a cluster takes a few tenths of a second, most of it importing Dask in
    # one thread of this process while the other core idles. Meanwhile the calling
    # process runs blocks itself, one at a time (a few tens of ms), until no core is
    # idle: until Dask is imported for a local cluster of one worker (which then
    # takes the core the user gave it), until connected for a remote scheduler (its
    # workers are elsewhere). Two or more local workers: see _run_with_spare.
    #
    # Block 0 runs first, alone: it makes every import a block needs (numpy's lazy
    # modules, the progress display's), so that this thread never imports while the
    # start thread imports Dask. A Ctrl-C landing in an import here can be
    # swallowed and leave a module lock held, which the start thread then waited
    # on for ever: the command hung (about 1 run in 30 interrupted 0.15 s in).
    grid, fold = _first_block(study, progress)
    imported = threading.Event()
    connection = _start_in_thread(workers, scheduler, imported)

    def handed_over() -> bool:
        return connection.done() or (scheduler is None and imported.is_set())

    try:
        here = chunks(study.n_blocks, 1, first=1)
        _run_here(fold, grid, here, until=handed_over)
        first = study.n_blocks - len(here)  # blocks run here
    except BaseException:
        _abandon(connection)
        raise
    client, cluster = connection.result()
    try:
        _run_dask(client, fold, grid, _dask_plan(study, chunk_trials, workers or 1, first))
        return fold.total, grid
    finally:
        close(client, cluster)


def _run_with_spare(
    study: mc.Study, chunk_trials: int | None, workers: int, progress: Callable | None
) -> tuple[mc.Summary, mc.Grid]:
    """Two or more local workers: a forked helper runs blocks while the cluster starts.

    The user gave the run ``workers`` cores. Starting the cluster (importing
    Dask, then forking the workers) keeps one busy; the helper
    (:class:`_spare.Spare`) runs block 0 (the grid's) and then blocks from
    the end of the study on another, at full speed, until the cluster is
    up. Computing in this process instead shares the GIL with the import:
    two blocks got done in the time the helper does fifteen
    (benchmarks/README.md).
    """
    from calibrator.analysis import _spare

    spare = connection = None
    try:
        # Forked first, before Dask starts threads here. The child runs only numpy
        # and a pipe, nothing another thread (a progress bar's) could have left locked.
        spare = _spare.Spare(study, low=1)
        # The cluster starts in a thread, as for one worker: Ctrl-C here then never
        # lands inside Dask's start-up (which then fails its own clean-up at exit).
        connection = _start_in_thread(workers, None, threading.Event())
        client, cluster = connection.result()
    except BaseException:
        if connection is not None:
            _abandon(connection)
        if spare is not None:
            spare.close()
        raise
    try:
        end = spare.stop()  # the helper's blocks: 0, and end.. (it claims after block 0)
        grid = spare.grid()
        theirs = list(range(end, study.n_blocks))
        if grid is None:  # it failed before block 0 was done: that is ours
            grid, fold = _first_block(study, progress)
        else:
            fold = _Fold(study, progress)
            theirs.insert(0, 0)
        futures = _submit(client, fold, grid, _dask_plan(study, chunk_trials, workers, 1, end))
        helped = spare.result()  # at most one block's wait; the workers are at it
        if helped is None:  # the helper failed: its blocks go to the cluster too
            futures.update(_submit(client, fold, grid, [[k] for k in theirs]))
        else:
            fold.add(theirs, helped)
        _gather(futures, fold)
        return fold.total, grid
    finally:
        spare.close()
        close(client, cluster)


def _first_block(study: mc.Study, progress: Callable | None) -> tuple[mc.Grid, _Fold]:
    """The study's grid, and a fold holding block 0, which the grid's ranges are drawn from."""
    grid, summary = mc.first_block(study)
    fold = _Fold(study, progress)
    fold.add([0], summary)
    return grid, fold


def _blocks_per_chunk(study: mc.Study, chunk_trials: int | None, workers: int) -> int:
    if chunk_trials is None:
        return default_blocks_per_chunk(study.n_blocks, workers)
    return -(-chunk_trials // mc.BLOCK)


def _dask_plan(
    study: mc.Study, chunk_trials: int | None, workers: int, first: int, end: int | None = None
) -> list[list[int]]:
    """The chunks of blocks ``first..end-1`` for the cluster: the user's size, or even ones."""
    end = study.n_blocks if end is None else end
    if chunk_trials is not None:
        return chunks(end, _blocks_per_chunk(study, chunk_trials, workers), first)
    left = end - first
    # About four per worker to keep them all busy, of at most 50 blocks.
    return even_chunks(end, max(4 * workers, -(-left // 50)), first)


@dataclass
class _Fold:
    """The chunks' summaries folded into one, and the progress reported after each."""

    study: mc.Study
    progress: Callable[[int, int], None] | None
    total: mc.Summary = field(default_factory=mc.Summary)
    done: int = 0

    def add(self, blocks: list[int], summary: mc.Summary) -> None:
        self.total.merge(summary)
        self.done += sum(self.study.block_size(k) for k in blocks)
        if self.progress:
            self.progress(self.done, self.study.trials)


def _run_here(
    fold: _Fold, grid: mc.Grid, plan: list[list[int]], until: Callable[[], bool] = lambda: False
) -> None:
    """Run chunks from the front of ``plan`` in this process until it is empty or ``until()``.

    ``until`` is asked between chunks; the chunks run are removed from ``plan``.
    """
    while plan and not until():
        blocks = plan.pop(0)
        fold.add(blocks, mc.run_chunk(fold.study, grid, blocks))


def local_cluster(workers: int) -> Any:
    """A Dask ``LocalCluster`` of ``workers`` single-threaded worker processes.

    Dask's nanny sets ``MALLOC_TRIM_THRESHOLD_`` in its workers. Setting any
    malloc tunable turns off glibc's dynamic mmap threshold, so every array
    above 128 kB of a block is mmap'ed and page-faulted afresh: a chunk ran
    1.7-2x slower in a worker than in the calling process
    (benchmarks/analyze_misalignment.py). These workers keep glibc's default.

    Without a dashboard the workers' statistical profiler and system monitor
    have no reader: off or slowed, two workers on two cores ran 2·10⁶ trials
    about 8 % faster (benchmarks/analyze_misalignment.py).

    The workers are forked, not spawned: a spawned worker imports Python,
    numpy, Dask and this package afresh, about half a second of start-up and
    a fifth of a second to shut down per cluster on two cores; a forked one
    starts in under a tenth (measured with two workers). Their nannies look
    for the workers' start-up message every 2 ms, not 50 (:func:`_nanny_poll`).
    """
    import dask
    from dask.distributed import LocalCluster

    settings = {
        "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
        "distributed.worker.multiprocessing-method": "fork",
        # The statistical profiler samples the running chunk's stack every 10 ms for a
        # dashboard nobody opens here; each sample takes the GIL from the chunk.
        "distributed.worker.profile.enabled": False,
        # Likewise the event loops' 20 ms tick (a blocked-loop warning) and the 0.5 s
        # system monitor (dashboard figures): with a worker on every core, every wake-up
        # of the scheduler's and workers' loops is taken from a chunk.
        "distributed.admin.tick.interval": "1s",
        "distributed.admin.system-monitor.interval": "5s",
    }
    with dask.config.set(settings), _nanny_poll(NANNY_POLL_S):
        return LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            # Dask's own log lines stay off the user's terminal: a worker logs a
            # traceback at ERROR when its heartbeat is in flight as the scheduler
            # closes (3 of about 160 runs that succeeded). Failures reach the caller as
            # exceptions, which the CLI reports in one line.
            silence_logs=logging.CRITICAL,
        )


#: How often a starting nanny looks for its worker's "started" message (s).
NANNY_POLL_S = 0.002


@contextmanager
def _nanny_poll(interval_s: float) -> Iterator[None]:
    """Dask's nannies look for their workers' start-up message every ``interval_s`` meanwhile.

    Dask polls every 50 ms (``WorkerProcess._init_msg_interval``, not in its
    configuration). A forked worker is up 25-35 ms after its fork and then
    waits for the next poll: two workers' cluster took 75 ms to start, 53 ms
    polled every 2 ms (benchmarks/README.md). A Dask without the attribute
    is left alone; the old value is put back afterwards.
    """
    from distributed.nanny import WorkerProcess

    name = "_init_msg_interval"
    old = getattr(WorkerProcess, name, None)
    if not isinstance(old, float):
        yield
        return
    setattr(WorkerProcess, name, interval_s)
    try:
        yield
    finally:
        setattr(WorkerProcess, name, old)


def _start_in_thread(
    workers: int | None, scheduler: str | None, imported: threading.Event
) -> Future:
    """:func:`_start` in a thread of its own: the future of ``(client, cluster)``.

    A daemon thread: a command interrupted while it imports Dask exits
    without waiting for it. (Ctrl-C landing in an import in the main thread
    can leave a module lock that this thread then waits on for ever; a
    non-daemon thread, joined at exit, hung the command.)
    """
    connection: Future = Future()

    def start() -> None:
        connection.set_running_or_notify_cancel()
        try:
            connection.set_result(_start(workers, scheduler, imported))
        except BaseException as exc:  # noqa: BLE001 - handed to whoever waits
            connection.set_exception(exc)

    threading.Thread(target=start, name="dask-start", daemon=True).start()
    return connection


def _start(
    workers: int | None, scheduler: str | None, imported: threading.Event
) -> tuple[Any, Any]:
    """Import Dask, set ``imported``, then :func:`connect` (run in a thread)."""
    try:
        _import_dask()
    finally:
        imported.set()
    return connect(workers, scheduler)


def _import_dask() -> None:
    import dask.distributed  # noqa: F401


def connect(workers: int | None, scheduler: str | None) -> tuple[Any, Any]:
    """``(client, cluster)``: a client of ``scheduler`` (no cluster) or of a new local cluster.

    Parameters
    ----------
    workers : int or None
        Processes of the local cluster (1 when None); ignored with ``scheduler``.
    scheduler : str or None
        Address of a running Dask scheduler.

    Raises
    ------
    CalibrationError
        The scheduler cannot be reached.

    Close both with :func:`close`.
    """
    from dask.distributed import Client

    if scheduler is not None:
        try:
            return Client(scheduler, timeout="10s"), None
        except (OSError, TimeoutError, ValueError) as exc:
            raise CalibrationError(f"cannot reach Dask scheduler {scheduler}: {exc}") from None
    cluster = local_cluster(workers or 1)
    return Client(cluster), cluster


def close(client: Any, cluster: Any) -> None:
    """Close what :func:`connect` opened: the client, then the local cluster if any."""
    client.close()
    if cluster is not None:
        cluster.close()


#: After a failure (Ctrl-C), how long the run waits for a cluster still starting,
#: to close it itself (s): a start takes a few tenths.
ABANDON_WAIT_S = 5.0


def _abandon(connection: Future) -> None:
    """Close what a start in progress makes, once made; the run has failed meanwhile.

    Waits for it at most :data:`ABANDON_WAIT_S`, so that the cluster is
    closed before Python's exit does it (which logs, and fails its own
    checks on a half-started cluster). A start that takes longer, or a
    second Ctrl-C, leaves it to a callback: the start thread is a daemon,
    and a start stuck for good (an import that a Ctrl-C broke) dies with
    the process.
    """
    try:
        connection.result(timeout=ABANDON_WAIT_S)
    except BaseException:  # noqa: BLE001 - failed, still starting, or interrupted again
        connection.add_done_callback(_close_connection)
        return
    _close_connection(connection)


def _close_connection(connection: Future) -> None:
    """Close a cluster that finished starting after the run had already failed."""
    if not connection.cancelled() and connection.exception() is None:
        close(*connection.result())


def _named(blocks: list[int]) -> str:
    """``block 3`` or ``blocks 3-7``, for messages."""
    return f"blocks {blocks[0]}-{blocks[-1]}" if len(blocks) > 1 else f"block {blocks[0]}"


def _run_dask(client: Any, fold: _Fold, grid: mc.Grid, plan: list[list[int]]) -> None:
    """Run ``plan``'s chunks on ``client``'s workers, folding them in as they finish."""
    _gather(_submit(client, fold, grid, plan), fold)


def _submit(client: Any, fold: _Fold, grid: mc.Grid, plan: list[list[int]]) -> dict:
    """Send ``plan``'s chunks to ``client``'s workers: ``{future: blocks}``.

    Each task carries the study and grid itself (under 2 kB pickled), not a
    reference to copies scattered to the workers: a worker that dies takes
    its copy with it, and with none left (one worker) Dask cancels every
    task that needs it, where a self-contained task is retried on the
    restarted worker.
    """
    return {client.submit(mc.run_chunk, fold.study, grid, blocks): blocks for blocks in plan}


def _gather(futures: dict, fold: _Fold) -> None:
    """Fold in the chunks of ``futures`` (from :func:`_submit`) as they finish."""
    from dask.distributed import KilledWorker, as_completed

    if not futures:
        return
    for future in as_completed(futures):
        blocks = futures[future]
        try:
            result = future.result()
        except ModuleNotFoundError as exc:
            raise CalibrationError(
                f"a Dask worker cannot import {exc.name!r}: install calibrator on every worker"
            ) from None
        except KilledWorker:
            raise CalibrationError(
                f"a Dask worker died running {_named(blocks)}, each time it was tried"
                " (out of memory, or killed by a signal)"
            ) from None
        except CancelledError as exc:  # e.g. another client restarted the cluster
            reason = getattr(exc, "reason", None) or "no reason given"
            raise CalibrationError(
                f"the Dask cluster cancelled {_named(blocks)} before it finished ({reason})"
            ) from None
        fold.add(blocks, result)
        future.release()
