"""The forked helper that runs blocks while a cluster starts: real processes, no Dask."""

import multiprocessing
import os
import signal
import time

import numpy as np
import pytest

from calibrator.analysis import _spare, arm
from calibrator.analysis import misalignment as mc


def study(n_blocks, seed=7):
    return mc.Study(arm.build(), 0.05, mc.PAPER_H_MM, n_blocks * mc.BLOCK - 3, seed)


def same(a, b):
    """Two summaries hold the same blocks and the same numbers, to the bit."""
    assert sorted(a.sums) == sorted(b.sums)
    for k in a.sums:
        np.testing.assert_array_equal(a.sums[k], b.sums[k])
    for name in ("hist_r", "maps", "hist_rot", "hist_axis", "outside"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert (a.count, a.max_r) == (b.count, b.max_r)
    np.testing.assert_array_equal(a.max_abs_rot, b.max_abs_rot)
    np.testing.assert_array_equal(a.max_axis, b.max_axis)


def helper_pid():
    (child,) = multiprocessing.active_children()
    return child.pid


def test_left_alone_the_helper_runs_every_block_it_may_from_the_top():
    s = study(4)
    grid = mc.make_grid(s)
    spare = _spare.Spare(s, grid, low=1)
    time.sleep(1.0)  # three blocks of about 20 ms each
    end = spare.stop()
    summary = spare.result()
    assert end == 1  # it claimed all of 1..3, and nothing below its floor
    same(summary, mc.run_chunk(s, grid, [1, 2, 3]))
    assert s.trials - mc.BLOCK == summary.count
    assert multiprocessing.active_children() == []


def test_stopped_at_once_the_helper_sends_exactly_the_blocks_it_claimed():
    s = study(40)
    grid = mc.make_grid(s)
    for _ in range(3):
        spare = _spare.Spare(s, grid, low=1)
        end = spare.stop()
        summary = spare.result()
        # It may have claimed none, or the one it was starting: those, and only those.
        assert end in (s.n_blocks, s.n_blocks - 1)
        same(summary, mc.run_chunk(s, grid, range(end, s.n_blocks)))
    assert multiprocessing.active_children() == []


def test_stopped_mid_run_its_blocks_and_the_callers_make_up_the_study():
    s = study(60)
    grid = mc.make_grid(s)
    spare = _spare.Spare(s, grid, low=1)
    time.sleep(0.15)
    end = spare.stop()
    summary = spare.result()
    assert 1 < end < s.n_blocks - 1  # it ran some, not all
    same(summary, mc.run_chunk(s, grid, range(end, s.n_blocks)))
    whole = mc.run_chunk(s, grid, range(s.n_blocks))
    here = mc.run_chunk(s, grid, range(end))
    assert mc.statistics(here.merge(summary), grid) == mc.statistics(whole, grid)


def test_a_helper_that_fails_sends_nothing_and_its_claims_stay(monkeypatch):
    s = study(5)
    grid = mc.make_grid(s)
    simulate = mc.simulate_block

    def fails_at_3(study, k):
        if k == 3:
            raise MemoryError("no room for block 3")
        return simulate(study, k)

    monkeypatch.setattr(mc, "simulate_block", fails_at_3)  # the forked helper inherits it
    spare = _spare.Spare(s, grid, low=1)
    time.sleep(0.5)
    end = spare.stop()
    assert spare.result() is None
    # It had claimed 4 and then 3: both are the caller's to run again.
    assert end == 3
    assert multiprocessing.active_children() == []


def test_a_helper_killed_under_a_block_counts_as_failed(monkeypatch):
    s = study(5)
    grid = mc.make_grid(s)
    simulate = mc.simulate_block

    def killed_at_2(study, k):
        if k == 2:
            os.kill(os.getpid(), signal.SIGKILL)
        return simulate(study, k)

    monkeypatch.setattr(mc, "simulate_block", killed_at_2)
    spare = _spare.Spare(s, grid, low=1)
    time.sleep(0.5)
    assert spare.stop() == 2
    assert spare.result() is None
    assert multiprocessing.active_children() == []


def test_the_helper_ignores_ctrl_c_which_the_caller_handles():
    s = study(60)
    grid = mc.make_grid(s)
    spare = _spare.Spare(s, grid, low=1)
    time.sleep(0.05)
    os.kill(helper_pid(), signal.SIGINT)  # as the terminal sends it to the whole group
    time.sleep(0.05)
    end = spare.stop()
    summary = spare.result()
    same(summary, mc.run_chunk(s, grid, range(end, s.n_blocks)))


def test_closing_ends_a_running_helper_at_once():
    s = study(500)  # ten seconds of blocks
    spare = _spare.Spare(s, mc.make_grid(s), low=1)
    time.sleep(0.05)
    started = time.monotonic()
    spare.close()
    spare.close()  # twice is fine
    assert time.monotonic() - started < 1.0
    assert multiprocessing.active_children() == []


def test_a_lock_never_released_is_taken_as_a_hung_helper(monkeypatch):
    s = study(200)
    spare = _spare.Spare(s, mc.make_grid(s), low=1)
    monkeypatch.setattr(_spare, "LOCK_WAIT_S", 0.05)
    lock = spare._lock  # as if the helper died holding it
    assert lock.acquire(timeout=5)
    try:
        started = time.monotonic()
        end = spare.stop()
        assert time.monotonic() - started < 1.0
    finally:
        lock.release()
    assert 1 <= end <= s.n_blocks
    assert spare.result() is None  # nothing it sent would count: the caller reruns end..
    assert multiprocessing.active_children() == []


@pytest.mark.parametrize("low", [1, 3])
def test_the_helper_never_claims_below_its_floor(low):
    s = study(3)
    grid = mc.make_grid(s)
    spare = _spare.Spare(s, grid, low=low)
    time.sleep(0.5)
    end = spare.stop()
    summary = spare.result()
    assert end == min(low, s.n_blocks)
    assert sorted(summary.sums) == list(range(end, s.n_blocks))
