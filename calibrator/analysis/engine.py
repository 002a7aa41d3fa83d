"""Running a Monte Carlo study's chunks: in-process, on a LocalCluster, or on a cluster.

Dask does the scheduling (``dask.distributed``); this module only cuts a
study into chunks of whole blocks and folds the chunks' summaries together.
Dask is imported only when a cluster is asked for.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable
from typing import Any

from calibrator.analysis import misalignment as mc
from calibrator.errors import CalibrationError


def chunks(n_blocks: int, blocks_per_chunk: int) -> list[list[int]]:
    """Consecutive runs of block indices, ``blocks_per_chunk`` at a time."""
    step = max(1, int(blocks_per_chunk))
    return [list(range(i, min(i + step, n_blocks))) for i in range(0, n_blocks, step)]


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
    grid = mc.make_grid(study)
    if chunk_trials is None:
        per_chunk = default_blocks_per_chunk(study.n_blocks, workers or 1)
    else:
        per_chunk = -(-chunk_trials // mc.BLOCK)
    plan = chunks(study.n_blocks, per_chunk)
    if workers is None and scheduler is None:
        return _run_local(study, grid, plan, progress), grid
    return _run_dask(study, grid, plan, workers, scheduler, progress), grid


def _trials(study, blocks):
    return sum(study.block_size(k) for k in blocks)


def _run_local(study, grid, plan, progress):
    total, done = mc.Summary(), 0
    for blocks in plan:
        total.merge(mc.run_chunk(study, grid, blocks))
        done += _trials(study, blocks)
        if progress:
            progress(done, study.trials)
    return total


def local_cluster(workers: int) -> Any:
    """A Dask ``LocalCluster`` of ``workers`` single-threaded worker processes.

    Dask's nanny sets ``MALLOC_TRIM_THRESHOLD_`` in its workers. Setting any
    malloc tunable turns off glibc's dynamic mmap threshold, so every array
    above 128 kB of a block is mmap'ed and page-faulted afresh: a chunk ran
    1.7-2x slower in a worker than in the calling process
    (benchmarks/analyze_misalignment.py). These workers keep glibc's default.
    """
    import dask
    from dask.distributed import LocalCluster

    with dask.config.set({"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}):
        return LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            silence_logs=logging.ERROR,
        )


def _run_dask(study, grid, plan, workers, scheduler, progress):
    from dask.distributed import Client, as_completed

    if scheduler is not None:
        try:
            client = Client(scheduler, timeout="10s")
        except (OSError, TimeoutError, ValueError) as exc:
            raise CalibrationError(f"cannot reach Dask scheduler {scheduler}: {exc}") from None
        cluster = None
    else:
        cluster = local_cluster(workers)
        client = Client(cluster)
    try:
        # One copy of the (small) study and grid per worker, not one per chunk.
        study_f, grid_f = client.scatter([study, grid], broadcast=True)
        futures = [client.submit(mc.run_chunk, study_f, grid_f, blocks) for blocks in plan]
        sizes = {f.key: _trials(study, blocks) for f, blocks in zip(futures, plan, strict=True)}
        total, done = mc.Summary(), 0
        for future in as_completed(futures):
            try:
                result = future.result()
            except ModuleNotFoundError as exc:
                raise CalibrationError(
                    f"a Dask worker cannot import {exc.name!r}: install calibrator on every worker"
                ) from None
            total.merge(result)
            done += sizes[future.key]
            future.release()
            if progress:
                progress(done, study.trials)
        return total
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
