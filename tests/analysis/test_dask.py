"""The same study on a real Dask LocalCluster gives the in-process result, to the bit."""

import copy
import multiprocessing
import os
import signal
import subprocess
import sys
import threading
import time

import pytest

from calibrator.analysis import arm, engine
from calibrator.analysis import misalignment as mc
from calibrator.errors import CalibrationError


def test_local_cluster_matches_in_process():
    study = mc.Study(arm.build(), 0.05, mc.PAPER_H_MM, 2 * mc.BLOCK + 500, seed=3)
    local, grid = engine.run(study)
    seen = []
    remote, _ = engine.run(
        study, workers=2, chunk_trials=mc.BLOCK, progress=lambda d, t: seen.append((d, t))
    )
    assert mc.statistics(remote, grid) == mc.statistics(local, grid)
    # Progress after what the helper ran (block 0 and some from the top) and each chunk.
    assert seen[-1] == (study.trials, study.trials)
    assert [d for d, _ in seen] == sorted({d for d, _ in seen})
    # The cluster's worker processes, and the helper, are gone once the run returns.
    assert multiprocessing.active_children() == []


def test_existing_scheduler_gets_the_chunks():
    from dask.distributed import LocalCluster

    study = mc.Study(arm.build(), 0.05, mc.PAPER_H_MM, mc.BLOCK + 10, seed=4)
    local, grid = engine.run(study)
    with LocalCluster(
        n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster:
        remote, _ = engine.run(study, scheduler=cluster.scheduler_address, chunk_trials=1)
        # The run closes its own client but leaves the user's cluster running.
        assert len(cluster.scheduler_info["workers"]) == 1
    assert mc.statistics(remote, grid) == mc.statistics(local, grid)
    assert multiprocessing.active_children() == []


def test_local_workers_keep_glibcs_dynamic_malloc_thresholds(monkeypatch):
    # Dask's nanny would set MALLOC_TRIM_THRESHOLD_, which turns off glibc's
    # dynamic mmap threshold and made a chunk run about 2x slower in a worker.
    from dask.distributed import Client

    # A plain LocalCluster earlier in this process leaves the variable in
    # os.environ (Dask sets it in the nanny's process), and workers inherit it.
    monkeypatch.delenv("MALLOC_TRIM_THRESHOLD_", raising=False)
    with engine.local_cluster(1) as cluster, Client(cluster) as client:
        seen = client.submit(os.environ.get, "MALLOC_TRIM_THRESHOLD_", pure=False).result(60)
        blas = client.submit(os.environ.get, "OPENBLAS_NUM_THREADS", pure=False).result(60)
    assert seen is None
    assert blas == "1"  # the rest of Dask's worker settings stay
    assert multiprocessing.active_children() == []


def test_nannies_poll_their_starting_workers_quickly_then_dask_is_as_before(monkeypatch):
    # Dask's nanny looks for its worker's start-up message every 50 ms, most of a
    # forked worker's start; the engine's clusters have it looked for every 2 ms.
    from distributed.nanny import WorkerProcess

    before = WorkerProcess._init_msg_interval
    polled = []
    wait = WorkerProcess._wait_until_connected

    async def watched(self, *args, **kwargs):
        polled.append(self._init_msg_interval)
        return await wait(self, *args, **kwargs)

    monkeypatch.setattr(WorkerProcess, "_wait_until_connected", watched)
    with engine.local_cluster(2):
        assert WorkerProcess._init_msg_interval == before  # only while it starts
    assert polled == [engine.NANNY_POLL_S] * 2
    assert engine.NANNY_POLL_S < before
    assert multiprocessing.active_children() == []


def test_a_dask_without_the_nanny_poll_interval_is_left_alone(monkeypatch):
    from distributed.nanny import WorkerProcess

    monkeypatch.delattr(WorkerProcess, "_init_msg_interval")
    with engine._nanny_poll(0.002):
        assert not hasattr(WorkerProcess, "_init_msg_interval")
    assert not hasattr(WorkerProcess, "_init_msg_interval")


_LOGGING_WORKER = """
import logging

from dask.distributed import Client

from calibrator.analysis import engine


def log(message):
    logging.getLogger("distributed.worker").error(message)


with engine.local_cluster(1) as cluster, Client(cluster) as client:
    client.submit(log, "heartbeat failed", pure=False).result()
    print(client.submit(sum, [1, 2]).result())
"""


def test_dask_log_lines_from_local_workers_stay_off_the_users_terminal(tmp_path):
    # A worker logs a traceback at ERROR when its heartbeat is in flight as the
    # scheduler closes (3 of about 160 runs that succeeded). Failures reach the
    # caller as exceptions instead, which the CLI reports in one line. A process
    # of its own: the workers write to the terminal the caller had when it forked.
    script = tmp_path / "logging_worker.py"
    script.write_text(_LOGGING_WORKER)
    run = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0 and run.stdout.strip() == "3", run.stderr
    assert "heartbeat failed" not in run.stderr


def test_a_worker_that_dies_fails_the_run_in_one_line(monkeypatch):
    # A worker killed under its chunk (the kernel's out-of-memory killer, a signal)
    # is restarted and the chunk retried; when it keeps dying, the run stops with
    # one line instead of Dask's KilledWorker traceback.
    caller = os.getpid()
    run_chunk = mc.run_chunk

    def dies_in_a_worker(study, grid, blocks):
        if os.getpid() != caller:
            os.kill(os.getpid(), signal.SIGKILL)
        return run_chunk(study, grid, blocks)

    monkeypatch.setattr(mc, "run_chunk", dies_in_a_worker)  # forked workers inherit it
    study = mc.Study(arm.build(), 0.05, mc.PAPER_H_MM, 40 * mc.BLOCK, seed=5)
    died = r"^a Dask worker died running blocks? \d+(-\d+)?, each time it was tried \(out of"
    with pytest.raises(CalibrationError, match=died):
        engine.run(study, workers=1)
    assert multiprocessing.active_children() == []


def test_a_worker_that_dies_once_is_replaced_and_the_result_is_the_same(monkeypatch, tmp_path):
    # The chunk it was running is retried on the restarted worker, and blocks are
    # deterministic: the statistics are those of an undisturbed run, to the bit.
    caller, died = os.getpid(), tmp_path / "died"
    run_chunk = mc.run_chunk

    def dies_once_in_a_worker(study, grid, blocks):
        if os.getpid() != caller and not died.exists():
            died.touch()
            os.kill(os.getpid(), signal.SIGKILL)
        return run_chunk(study, grid, blocks)

    study = mc.Study(arm.build(), 0.05, mc.PAPER_H_MM, 40 * mc.BLOCK, seed=5)
    local, grid = engine.run(study)
    monkeypatch.setattr(mc, "run_chunk", dies_once_in_a_worker)
    # One worker: nothing else holds what it held.
    remote, _ = engine.run(study, workers=1)
    assert died.exists()
    assert mc.statistics(remote, grid) == mc.statistics(local, grid)
    assert multiprocessing.active_children() == []


def test_a_cluster_restarted_under_the_run_fails_it_in_one_line():
    # Another client of the user's cluster restarts it: Dask cancels this run's
    # chunks, and the run stops with one line instead of Dask's traceback.
    from dask.distributed import Client, LocalCluster

    study = mc.Study(arm.build(), 0.05, mc.PAPER_H_MM, 60 * mc.BLOCK, seed=4)

    with LocalCluster(
        n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster:

        def restart():
            deadline = time.monotonic() + 30
            while not cluster.scheduler.tasks and time.monotonic() < deadline:
                time.sleep(0.005)  # until the run's chunks are on the cluster
            with Client(cluster.scheduler_address) as other:
                other.restart()

        restarter = threading.Thread(target=restart)
        restarter.start()
        cancelled = r"^the Dask cluster cancelled blocks? \d+(-\d+)? before it finished \(scheduler"
        with pytest.raises(CalibrationError, match=cancelled):
            engine.run(study, scheduler=cluster.scheduler_address, chunk_trials=mc.BLOCK)
        restarter.join(120)
        assert not restarter.is_alive(), "the restart did not end within 120 s"


def spy(monkeypatch, owner, name, log):
    """Record what ``owner.name`` returns (it still runs), as it was then."""
    real = getattr(owner, name)

    def recorded(*args, **kwargs):
        out = real(*args, **kwargs)
        log.append(copy.copy(out))
        return out

    monkeypatch.setattr(owner, name, recorded)


def test_with_two_workers_a_helper_runs_blocks_while_the_cluster_starts(monkeypatch):
    # The run forks a helper onto the core the cluster's start leaves idle; it
    # runs block 0 (the grid's), then blocks from the top until the cluster is
    # up, and the cluster the rest.
    from calibrator.analysis import _spare

    # 80 blocks, about 1.5 s of one core: more than a loaded machine's cluster start.
    study = mc.Study(arm.build(), 0.05, mc.PAPER_H_MM, 80 * mc.BLOCK, seed=6)
    local, grid = engine.run(study)
    ends, sent = [], []
    spy(monkeypatch, _spare.Spare, "stop", ends)
    spy(monkeypatch, engine, "_submit", sent)
    remote, remote_grid = engine.run(study, workers=2)
    assert mc.statistics(remote, grid) == mc.statistics(local, grid)
    assert remote_grid.r_max == grid.r_max and (remote_grid.xyz_lo == grid.xyz_lo).all()
    (end,) = ends
    on_cluster = sorted(k for futures in sent for blocks in futures.values() for k in blocks)
    assert 1 < end < study.n_blocks  # both had blocks here (the start takes ~0.3 s)
    assert on_cluster == list(range(1, end))
    assert multiprocessing.active_children() == []


def claims_three_and_dies(after_the_grid):
    """A helper's stand-in: (block 0 and the grid, sent,) three blocks claimed, then death."""

    def work(study, claims, lock, sender, receiver, caller):
        if after_the_grid:
            sender.send(mc.make_grid(study))
        with lock:
            claims[0] -= 3
        os._exit(3)

    return work


@pytest.mark.parametrize("after_the_grid, reruns", [(False, [9, 10, 11]), (True, [0, 9, 10, 11])])
def test_a_helper_that_dies_has_its_blocks_run_on_the_cluster(monkeypatch, after_the_grid, reruns):
    from calibrator.analysis import _spare

    study = mc.Study(arm.build(), 0.05, mc.PAPER_H_MM, 12 * mc.BLOCK, seed=6)
    local, grid = engine.run(study)
    sent = []
    monkeypatch.setattr(_spare, "_work", claims_three_and_dies(after_the_grid))
    spy(monkeypatch, engine, "_submit", sent)
    remote, _ = engine.run(study, workers=2)
    assert mc.statistics(remote, grid) == mc.statistics(local, grid)
    # The cluster's plan stops below the helper's claims; then it runs them too,
    # and block 0 if the helper had it (without a grid from it, the caller runs it).
    assert [sorted(k for b in f.values() for k in b) for f in sent] == [
        list(range(1, 9)),
        reruns,
    ]
    assert multiprocessing.active_children() == []
