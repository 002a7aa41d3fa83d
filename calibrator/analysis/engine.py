"""Running a Monte Carlo study's chunks: in-process, on a LocalCluster, or on a cluster.

Dask does the scheduling (``dask.distributed``); this module only cuts a
study into chunks of whole blocks and folds the chunks' summaries together.
Dask is imported only when a cluster is asked for.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any

from calibrator.analysis import misalignment as mc
from calibrator.errors import CalibrationError


def chunks(n_blocks: int, blocks_per_chunk: int, first: int = 0) -> list[list[int]]:
    """Consecutive runs of block indices ``first..n_blocks-1``, ``blocks_per_chunk`` at a time."""
    step = max(1, int(blocks_per_chunk))
    return [list(range(i, min(i + step, n_blocks))) for i in range(first, n_blocks, step)]


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
        grid = mc.make_grid(study)
        fold = _Fold(study, progress)
        _run_here(fold, grid, chunks(study.n_blocks, _blocks_per_chunk(study, chunk_trials, 1)))
        return fold.total, grid
    # Starting a cluster (importing Dask, the scheduler, forking the workers) takes a
    # few tenths of a second; the calling process meanwhile builds the grid and, on a
    # core the start-up leaves free (a remote scheduler, or fewer local workers than
    # cores), runs blocks itself instead of waiting, so one worker costs about what
    # in-process does. One block at a time (a few tens of ms), so the workers get the
    # rest as soon as they are up. With a worker on every core it only slowed their
    # start-up down (measured with spawned workers: 2 on 2 cores, 0.2-0.4 s slower).
    starting = ThreadPoolExecutor(max_workers=1, thread_name_prefix="dask-start")
    connection = starting.submit(_connect, workers, scheduler)
    starting.shutdown(wait=False)
    spare_core = workers is None or workers < (os.cpu_count() or 1)
    try:
        grid = mc.make_grid(study)
        fold = _Fold(study, progress)
        here = chunks(study.n_blocks, 1) if spare_core else []
        _run_here(fold, grid, here, until=connection.done)
        first = study.n_blocks - len(here) if spare_core else 0  # blocks run here
    except BaseException:
        connection.add_done_callback(_close_connection)
        raise
    client, cluster = connection.result()
    try:
        per_chunk = _blocks_per_chunk(study, chunk_trials, workers or 1)
        _run_dask(client, fold, grid, chunks(study.n_blocks, per_chunk, first))
        return fold.total, grid
    finally:
        _close(client, cluster)


def _blocks_per_chunk(study: mc.Study, chunk_trials: int | None, workers: int) -> int:
    if chunk_trials is None:
        return default_blocks_per_chunk(study.n_blocks, workers)
    return -(-chunk_trials // mc.BLOCK)


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

    The workers are forked, not spawned: a spawned worker imports Python,
    numpy, Dask and this package afresh, about half a second of start-up and
    a fifth of a second to shut down per cluster on two cores; a forked one
    starts in under a tenth (measured with two workers).
    """
    import dask
    from dask.distributed import LocalCluster

    settings = {
        "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
        "distributed.worker.multiprocessing-method": "fork",
    }
    with dask.config.set(settings):
        return LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            silence_logs=logging.ERROR,
        )


def _connect(workers: int | None, scheduler: str | None) -> tuple[Any, Any]:
    """``(client, cluster)``: a client of ``scheduler`` (no cluster) or of a new local cluster."""
    from dask.distributed import Client

    if scheduler is not None:
        try:
            return Client(scheduler, timeout="10s"), None
        except (OSError, TimeoutError, ValueError) as exc:
            raise CalibrationError(f"cannot reach Dask scheduler {scheduler}: {exc}") from None
    cluster = local_cluster(workers or 1)
    return Client(cluster), cluster


def _close(client: Any, cluster: Any) -> None:
    client.close()
    if cluster is not None:
        cluster.close()


def _close_connection(connection: Future) -> None:
    """Close a cluster that finished starting after the run had already failed."""
    if not connection.cancelled() and connection.exception() is None:
        _close(*connection.result())


def _run_dask(client: Any, fold: _Fold, grid: mc.Grid, plan: list[list[int]]) -> None:
    """Run ``plan``'s chunks on ``client``'s workers, folding them in as they finish."""
    from dask.distributed import as_completed

    if not plan:
        return
    # One copy of the (small) study and grid per worker, not one per chunk.
    study_f, grid_f = client.scatter([fold.study, grid], broadcast=True)
    futures = {client.submit(mc.run_chunk, study_f, grid_f, blocks): blocks for blocks in plan}
    for future in as_completed(futures):
        try:
            result = future.result()
        except ModuleNotFoundError as exc:
            raise CalibrationError(
                f"a Dask worker cannot import {exc.name!r}: install calibrator on every worker"
            ) from None
        fold.add(futures[future], result)
        future.release()
