"""The in-process engine: chunking never changes the result, which equals a direct computation.

No Dask cluster here (worker processes per mutant would be far too slow);
``test_dask.py`` compares the cluster paths with this in-process one.
"""

import os
import threading
import time
import types

import numpy as np
import pytest

from calibrator.analysis import arm, engine
from calibrator.analysis import misalignment as mc
from calibrator.errors import CalibrationError

TRIALS = 2 * mc.BLOCK + 7  # three blocks, the last one of 7 trials


def study(trials=TRIALS, seed=11):
    return mc.Study(arm.build(), 0.05, mc.PAPER_H_MM, trials, seed)


def direct(s):
    """|dP| and the position errors of every trial, block after block, with numpy."""
    dp = np.concatenate([mc.simulate_block(s, k)[0] for k in range(s.n_blocks)])
    return dp, np.linalg.norm(dp, axis=1)


def recorder():
    """A progress callback and the list of its calls."""
    seen = []
    return seen, lambda done, total: seen.append((done, total))


def test_every_chunking_gives_the_direct_result():
    s = study()
    dp, r = direct(s)
    first = None
    # chunk_trials -> progress calls: block 0 (the grid is drawn from it), then a call
    # per chunk of the rest; the default: about four chunks per worker, here one block each.
    for chunk_trials, n_chunks in ((None, 3), (1, 3), (mc.BLOCK + 1, 2), (10 * TRIALS, 2)):
        seen, progress = recorder()
        summary, grid = engine.run(s, chunk_trials=chunk_trials, progress=progress)
        assert summary.count == TRIALS and sorted(summary.sums) == [0, 1, 2]
        assert summary.max_r == r.max()
        counts, _ = np.histogram(r, bins=mc.N_RADIAL_BINS, range=(0.0, grid.r_max))
        assert np.abs(summary.hist_r - counts).sum() <= 2  # binning round-off at an edge, at most
        totals = summary.totals()
        np.testing.assert_allclose(totals[0:3], dp.sum(axis=0), rtol=1e-9, atol=1e-9)
        assert totals[12] == pytest.approx(r.sum(), rel=1e-12)
        # Progress after every chunk, counting whole blocks' trials, ending at the total.
        done = [d for d, _ in seen]
        assert len(seen) == n_chunks, chunk_trials
        assert all(t == TRIALS for _, t in seen) and done[-1] == TRIALS
        assert all(b > a for a, b in zip(done, done[1:], strict=False))
        assert set(done[:-1]) <= {mc.BLOCK, 2 * mc.BLOCK}
        # The statistics do not depend on the chunking, to the bit.
        stats = mc.statistics(summary, grid)
        first = first or stats
        assert stats == first


def test_without_progress_callback_the_result_is_the_same():
    s = study(trials=mc.BLOCK + 3)
    quiet, grid = engine.run(s, chunk_trials=1)
    loud, _ = engine.run(s, chunk_trials=1, progress=lambda *a: None)
    assert mc.statistics(quiet, grid) == mc.statistics(loud, grid)
    assert quiet.count == mc.BLOCK + 3


def test_grid_is_the_study_grid():
    s = study(trials=500)
    _, grid = engine.run(s)
    expected = mc.make_grid(s)
    assert grid.r_max == expected.r_max and grid.axis_hi == expected.axis_hi
    np.testing.assert_array_equal(grid.xyz_lo, expected.xyz_lo)


def test_chunks_are_consecutive_runs_of_whole_blocks():
    assert engine.chunks(7, 3) == [[0, 1, 2], [3, 4, 5], [6]]
    assert engine.chunks(6, 3) == [[0, 1, 2], [3, 4, 5]]
    assert engine.chunks(2, 5) == [[0, 1]]
    assert engine.chunks(3, 0) == [[0], [1], [2]]  # at least one block per chunk
    assert engine.chunks(0, 4) == []


@pytest.mark.parametrize("workers", [1, 2, 3, 8])
def test_default_chunks_keep_the_workers_busy_but_stay_small(workers):
    for n_blocks in range(1, 600):
        b = engine.default_blocks_per_chunk(n_blocks, workers)
        n_chunks = len(engine.chunks(n_blocks, b))
        assert 1 <= b <= 50
        if b < 50:
            # No more than about four chunks per worker ...
            assert n_chunks <= 4 * workers
            # ... and each chunk as small as that allows.
            if b > 1:
                assert len(engine.chunks(n_blocks, b - 1)) > 4 * workers
        else:
            # The cap binds only for studies big enough to keep every worker busy anyway.
            assert n_chunks >= 4 * workers
    assert engine.default_blocks_per_chunk(10, 0) == engine.default_blocks_per_chunk(10, 1)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (
            {"workers": 2, "scheduler": "tcp://127.0.0.1:1"},
            "give --workers or --scheduler, not both",
        ),
        (
            {"workers": 0},
            f"--workers must be in [1, {os.cpu_count()}] (this machine's cores), got 0",
        ),
        (
            {"workers": os.cpu_count() + 1},
            f"--workers must be in [1, {os.cpu_count()}] (this machine's cores), "
            f"got {os.cpu_count() + 1}",
        ),
        ({"chunk_trials": 0}, "--chunk must be >= 1 trial, got 0"),
        ({"chunk_trials": -5}, "--chunk must be >= 1 trial, got -5"),
    ],
)
def test_bad_run_options_are_refused_before_any_work(kwargs, message, monkeypatch):
    def no_work(*args):
        raise AssertionError("a chunk ran")

    monkeypatch.setattr(mc, "run_chunk", no_work)
    monkeypatch.setattr(mc, "make_grid", no_work)
    with pytest.raises(CalibrationError) as info:
        engine.run(study(trials=10), **kwargs)
    assert str(info.value) == message


class FakeClient:
    """Stands in for a Dask client: records its closing (the chunks go to ``_run_dask``)."""

    def __init__(self, log):
        self.log = log

    def close(self):
        self.log.append("closed")


@pytest.fixture
def planned(monkeypatch):
    """The chunks each run runs here and hands on, by path; none is simulated.

    Dask "is imported" once the calling process has run ``imported`` chunks,
    and the cluster "starts" once it has run ``held`` (counts, not a clock).
    The chunk that reaches either count returns only once the engine can see
    it (the engine's "imported" event set; the connection handed over), so
    which chunks run where does not depend on how threads are scheduled.
    """
    seen = {"local": [], "dask": [], "connect": [], "client": [], "held": 0, "imported": 0}
    ran = threading.Condition()
    up = threading.Event()
    events = []  # the engine's "imported" events, newest last

    def engine_event():
        events.append(threading.Event())
        return events[-1]

    def local_chunk(study, grid, blocks):
        with ran:
            seen["local"].append(list(blocks))
            ran.notify_all()
        if seen["imported"] and len(seen["local"]) == seen["imported"]:
            assert events[-1].wait(5)
        if seen["held"] and len(seen["local"]) >= seen["held"] and up.wait(5):
            time.sleep(0.05)  # the connection's future completes
        return mc.Summary()

    def wait_for(key):
        with ran:
            assert ran.wait_for(lambda: len(seen["local"]) >= seen[key], 5)

    def connect(workers, scheduler):
        seen["connect"].append((workers, scheduler))
        wait_for("held")
        up.set()
        return FakeClient(seen["client"]), None

    def dask(client, fold, grid, plan):
        up.clear()
        seen["dask"].append(list(plan))
        seen["progress"], seen["study"], seen["grid"] = fold.progress, fold.study, grid
        seen["done"] = fold.done

    monkeypatch.setattr(mc, "run_chunk", local_chunk)
    monkeypatch.setattr(
        engine, "threading", types.SimpleNamespace(Event=engine_event, Thread=threading.Thread)
    )
    monkeypatch.setattr(engine, "_import_dask", lambda: wait_for("imported"))
    monkeypatch.setattr(engine, "connect", connect)
    monkeypatch.setattr(engine, "_run_dask", dask)
    return seen


def test_default_plan_gives_each_worker_about_four_chunks(planned):
    s = study(trials=8 * mc.BLOCK)
    engine.run(s)
    # Block 0 is run with the grid, which is drawn from it; then chunks of the rest.
    assert planned["local"] == [[1, 2], [3, 4], [5, 6], [7]]
    cases = [
        ({"workers": 1}, (1, None)),
        ({"scheduler": "tcp://h:1"}, (None, "tcp://h:1")),
        ({"workers": 1, "chunk_trials": 3 * mc.BLOCK}, (1, None)),
    ]
    for kwargs, connected in cases:
        planned["local"].clear()
        engine.run(s, **kwargs)
        # Whatever ran here, one block at a time while the cluster started, the
        # cluster got the rest: every block once, in order.
        here = 1 + len(planned["local"])
        assert planned["local"] == [[k] for k in range(1, here)]
        plan = planned["dask"][-1]
        assert [k for chunk in plan for k in chunk] == list(range(here, 8))
        if "chunk_trials" in kwargs:
            assert plan == engine.chunks(8, 3, here)  # the user's size
        else:  # four even chunks per worker, or one block each
            assert plan == engine.even_chunks(8, 4, here)
        assert planned["connect"][-1] == connected
    _, grid = engine.run(s, workers=1, progress=print)
    assert planned["progress"] is print
    assert planned["study"] is s and planned["grid"] is grid
    assert planned["client"] == ["closed"] * 4


def test_the_cluster_gets_even_chunks_of_what_is_left(planned):
    s = study(trials=100 * mc.BLOCK)
    planned["held"] = planned["imported"] = 7
    engine.run(s, workers=1)
    here = 1 + len(planned["local"])
    assert here == 8
    plan = planned["dask"][-1]
    # 4 chunks (four per worker) of what the caller left, sizes differing by at most one.
    assert len(plan) == 4 and max(map(len, plan)) - min(map(len, plan)) <= 1
    assert [k for chunk in plan for k in chunk] == list(range(here, 100))


def test_even_chunks_are_consecutive_and_differ_by_at_most_one_block():
    assert engine.even_chunks(7, 3) == [[0, 1], [2, 3], [4, 5, 6]]
    assert engine.even_chunks(8, 3, 2) == [[2, 3], [4, 5], [6, 7]]
    assert engine.even_chunks(8, 5, 6) == [[6], [7]]  # no empty chunks
    assert engine.even_chunks(8, 3, 8) == [] and engine.even_chunks(0, 4) == []
    assert engine.even_chunks(5, 0) == [[0, 1, 2, 3, 4]]


def test_with_one_worker_the_calling_process_runs_blocks_while_dask_imports(planned):
    s = study(trials=8 * mc.BLOCK)
    planned["imported"] = 3
    calls, progress = recorder()
    engine.run(s, workers=1, progress=progress)
    # Dask is imported once three blocks (after block 0) ran here, and the caller
    # stops there: the worker has the core the user gave it (--workers N, N
    # cores), and the cluster gets the rest.
    here = 1 + len(planned["local"])
    assert here == 4 and planned["local"] == [[k] for k in range(1, here)]
    assert [k for chunk in planned["dask"][0] for k in chunk] == list(range(here, 8))
    assert planned["done"] == here * mc.BLOCK  # what the cluster's chunks add to
    assert calls == [(mc.BLOCK * k, 8 * mc.BLOCK) for k in range(1, here + 1)]
    assert planned["client"] == ["closed"]


def test_with_a_remote_scheduler_the_caller_works_until_connected(planned):
    s = study(trials=8 * mc.BLOCK)
    planned["imported"], planned["held"] = 1, 4  # its workers take no core here
    engine.run(s, scheduler="tcp://h:1")
    here = 1 + len(planned["local"])
    assert here in (5, 6) and planned["local"] == [[k] for k in range(1, here)]
    assert [k for chunk in planned["dask"][0] for k in chunk] == list(range(here, 8))


def test_chunks_can_start_at_any_block():
    assert engine.chunks(8, 3, 2) == [[2, 3, 4], [5, 6, 7]]
    assert engine.chunks(8, 3, 8) == []


@pytest.mark.parametrize("where", [{"workers": 1}, {"scheduler": "tcp://h:1"}])
def test_a_cluster_that_starts_after_the_run_failed_is_closed(planned, monkeypatch, where):
    s = study(trials=8 * mc.BLOCK)

    def fail_second(study, grid, blocks):
        planned["local"].append(list(blocks))
        if len(planned["local"]) == 2:
            raise KeyboardInterrupt
        return mc.Summary()

    monkeypatch.setattr(mc, "run_chunk", fail_second)
    started = threading.Event()
    connect = engine.connect

    def connect_later(workers, scheduler):
        started.wait(5)
        return connect(workers, scheduler)

    # Still importing Dask (a local cluster) or connecting (a remote one) when the
    # second block fails here.
    monkeypatch.setattr(engine, "_import_dask", lambda: started.wait(5))
    monkeypatch.setattr(engine, "connect", connect_later)
    monkeypatch.setattr(engine, "ABANDON_WAIT_S", 0.05)  # a start that outlasts the wait
    with pytest.raises(KeyboardInterrupt):
        engine.run(s, **where)
    started.set()
    for _ in range(500):  # the starting thread closes what it started, in its own time
        if planned["client"]:
            break
        threading.Event().wait(0.01)
    assert planned["client"] == ["closed"] and planned["dask"] == []


def test_a_start_that_ends_soon_after_the_failure_is_closed_before_the_run_ends(
    planned, monkeypatch
):
    # So that Python's exit does not close a cluster itself (it logs, and trips
    # on one half started).
    def fail_second(study, grid, blocks):
        planned["local"].append(list(blocks))
        if len(planned["local"]) == 2:
            threading.Timer(0.1, started.set).start()  # the start ends 0.1 s on
            raise KeyboardInterrupt
        return mc.Summary()

    monkeypatch.setattr(mc, "run_chunk", fail_second)
    started = threading.Event()
    monkeypatch.setattr(engine, "_import_dask", lambda: started.wait(5))
    with pytest.raises(KeyboardInterrupt):
        engine.run(study(trials=8 * mc.BLOCK), workers=1)
    assert planned["client"] == ["closed"] and planned["dask"] == []


def test_a_cluster_that_cannot_start_fails_the_run(planned, monkeypatch):
    def unreachable(workers, scheduler):
        raise CalibrationError("cannot reach Dask scheduler tcp://127.0.0.1:1: refused")

    monkeypatch.setattr(engine, "connect", unreachable)
    with pytest.raises(CalibrationError, match="cannot reach Dask scheduler"):
        engine.run(study(trials=8 * mc.BLOCK), scheduler="tcp://127.0.0.1:1")


@pytest.mark.parametrize("where", [{"workers": 1}, {"scheduler": "tcp://h:1"}])
def test_block_0_runs_before_the_cluster_starts_importing(planned, monkeypatch, where):
    # Block 0 makes every import a block needs, so this thread never imports while
    # the start thread imports Dask: a Ctrl-C in an import here could leave a
    # module lock held that the start thread then waits on for ever.
    calls, progress = recorder()
    done_when_started = []
    start = engine._start_in_thread

    def recorded(*args):
        done_when_started.append(list(calls))
        return start(*args)

    monkeypatch.setattr(engine, "_start_in_thread", recorded)
    engine.run(study(trials=8 * mc.BLOCK), progress=progress, **where)
    assert done_when_started == [[(mc.BLOCK, 8 * mc.BLOCK)]]
