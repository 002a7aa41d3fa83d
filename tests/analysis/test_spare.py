"""The forked helper that runs blocks while a cluster starts: real processes, no Dask."""

import multiprocessing
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from timeout_kit import within

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


def started(n_blocks, low=1, claimed_to=None):
    """A study, its grid and a helper; once it has claimed down to ``claimed_to``, if given.

    Waits on the claims themselves, not a clock: a loaded machine only
    makes it wait longer.
    """
    s = study(n_blocks)
    spare = _spare.Spare(s, low=low)
    deadline = time.monotonic() + 30
    while claimed_to is not None and spare._claims[0] > claimed_to:
        assert time.monotonic() < deadline, "the helper claimed nothing for 30 s"
        time.sleep(0.002)
    return s, mc.make_grid(s), spare


def stopped(spare):
    """``(end, grid, summary)``: where it stopped, and what it sent."""
    end = spare.stop()
    grid = within(spare.grid, what="the helper's grid")
    return end, grid, within(spare.result, what="the helper's summary")


def same_grid(a, b):
    assert (a.r_max, a.axis_hi) == (b.r_max, b.axis_hi)
    for name in ("xyz_lo", "xyz_hi", "rot_lo", "rot_hi"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))


def test_left_alone_the_helper_runs_block_0_then_every_block_it_may_from_the_top():
    s, grid, spare = started(4, claimed_to=1)
    end, sent, summary = stopped(spare)
    assert end == 1  # it claimed all of 1..3, and nothing below its floor
    same_grid(sent, grid)  # the grid's ranges come from block 0, as the caller's would
    same(summary, mc.run_chunk(s, grid, [0, 1, 2, 3]))
    assert s.trials == summary.count
    assert multiprocessing.active_children() == []


def test_stopped_at_once_the_helper_sends_block_0_and_exactly_the_blocks_it_claimed():
    for _ in range(3):
        s, grid, spare = started(40)
        end, sent, summary = stopped(spare)
        # It may have claimed none, or the one it was starting (a few more when this
        # process lost the core meanwhile): those, and only those.
        assert 1 <= end <= s.n_blocks
        same_grid(sent, grid)
        same(summary, mc.run_chunk(s, grid, [0, *range(end, s.n_blocks)]))
    assert multiprocessing.active_children() == []


def test_stopped_mid_run_its_blocks_and_the_clusters_make_up_the_study():
    s, grid, spare = started(200, claimed_to=197)
    end, _, summary = stopped(spare)
    assert 1 < end <= 197  # it ran some, not all
    same(summary, mc.run_chunk(s, grid, [0, *range(end, s.n_blocks)]))
    whole = mc.run_chunk(s, grid, range(s.n_blocks))
    rest = mc.run_chunk(s, grid, range(1, end))
    assert mc.statistics(rest.merge(summary), grid) == mc.statistics(whole, grid)


def test_a_helper_that_fails_sends_nothing_more_and_its_claims_stay(monkeypatch):
    simulate = mc.simulate_block

    def fails_at_3(study, k):
        if k == 3:
            raise MemoryError("no room for block 3")
        return simulate(study, k)

    monkeypatch.setattr(mc, "simulate_block", fails_at_3)  # the forked helper inherits it
    s, grid, spare = started(5, claimed_to=3)
    end, sent, summary = stopped(spare)
    same_grid(sent, grid)  # block 0 went well
    assert summary is None
    # It had claimed 4 and then 3: both are the caller's to run again, and block 0.
    assert end == 3
    assert multiprocessing.active_children() == []


def test_a_helper_that_fails_at_block_0_sends_no_grid_and_claims_nothing(monkeypatch):
    def fails(study, k):
        raise MemoryError(f"no room for block {k}")

    monkeypatch.setattr(mc, "simulate_block", fails)
    spare = _spare.Spare(study(5), low=1)
    assert stopped(spare) == (5, None, None)
    assert multiprocessing.active_children() == []


def test_a_helper_killed_under_a_block_counts_as_failed(monkeypatch):
    simulate = mc.simulate_block

    def killed_at_2(study, k):
        if k == 2:
            os.kill(os.getpid(), signal.SIGKILL)
        return simulate(study, k)

    monkeypatch.setattr(mc, "simulate_block", killed_at_2)
    _, grid, spare = started(5, claimed_to=2)
    end, sent, summary = stopped(spare)
    assert (end, summary) == (2, None)
    same_grid(sent, grid)
    assert multiprocessing.active_children() == []


def test_the_helper_ignores_ctrl_c_which_the_caller_handles():
    s, grid, spare = started(200, claimed_to=199)
    os.kill(helper_pid(), signal.SIGINT)  # as the terminal sends it to the whole group
    deadline = time.monotonic() + 30
    while spare._claims[0] > 197:  # it goes on to the next blocks
        assert time.monotonic() < deadline
        time.sleep(0.002)
    end, _, summary = stopped(spare)
    same(summary, mc.run_chunk(s, grid, [0, *range(end, s.n_blocks)]))


def test_closing_ends_a_running_helper_at_once():
    _, _, spare = started(500, claimed_to=499)  # ten seconds of blocks
    asked = time.monotonic()
    spare.close()
    spare.close()  # twice is fine
    assert time.monotonic() - asked < 1.0
    assert multiprocessing.active_children() == []


def test_a_lock_never_released_is_taken_as_a_hung_helper(monkeypatch):
    s, grid, spare = started(200)
    monkeypatch.setattr(_spare, "LOCK_WAIT_S", 0.05)
    lock = spare._lock  # as if the helper died holding it
    assert lock.acquire(timeout=5)
    try:
        asked = time.monotonic()
        end = spare.stop()
        assert time.monotonic() - asked < 1.0
    finally:
        lock.release()
    assert 1 <= end <= s.n_blocks
    sent = within(spare.grid, what="the helper's grid")  # still a grid, or none sent
    if sent is not None:
        same_grid(sent, grid)
    # Nothing else it sent counts: the caller reruns them.
    assert within(spare.result, what="the helper's summary") is None
    assert multiprocessing.active_children() == []


@pytest.mark.parametrize("low", [1, 3])
def test_the_helper_never_claims_below_its_floor(low):
    s, _, spare = started(3, low=low, claimed_to=low)
    time.sleep(0.1)  # time enough to claim below it, were it to
    end, _, summary = stopped(spare)
    assert end == low
    assert sorted(summary.sums) == [0, *range(end, s.n_blocks)]


_ORPHANING_CALLER = """
import os, sys, time
from calibrator.analysis import _spare, arm
from calibrator.analysis import misalignment as mc

spare = _spare.Spare(mc.Study(arm.build(), 0.05, mc.PAPER_H_MM, 500 * mc.BLOCK, 1), low=1)
print(spare._process.pid, flush=True)
time.sleep(0.3)  # the helper is at its blocks
os._exit(int(sys.argv[1]))  # the caller dies without a word (as under SIGKILL)
"""


def gone(pid, within_s):
    deadline = time.monotonic() + within_s
    while time.monotonic() < deadline:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return True
        with open(f"/proc/{pid}/stat") as stat:  # a zombie is gone too, once reaped
            if stat.read().rsplit(")", 1)[1].split()[0] == "Z":
                return True
        time.sleep(0.01)
    return False


@pytest.mark.skipif(not os.path.isdir("/proc"), reason="reads /proc")
def test_a_helper_never_outlives_its_caller(tmp_path):
    # Left running, it would compute for minutes, hold the caller's terminal
    # output open (a shell pipeline would never end), then block for ever
    # sending its summary.
    script, out = tmp_path / "caller.py", tmp_path / "out.txt"
    script.write_text(_ORPHANING_CALLER)
    with out.open("w") as sink:  # files, not pipes: a helper left behind must not hold us up
        code = subprocess.call(
            [sys.executable, str(script), "3"], stdout=sink, stderr=sink, timeout=120
        )
    assert code == 3, out.read_text()
    assert gone(int(out.read_text()), within_s=2.0)


class InterruptedStart:
    """A process whose start gets Ctrl-C midway (as a fork's at-fork handlers may)."""

    def __init__(self):
        self.finished = False

    def start(self):
        os.kill(os.getpid(), signal.SIGINT)
        for _ in range(1000):  # bytecode boundaries, where Python raises KeyboardInterrupt
            time.sleep(0.0001)
        self.finished = True


@pytest.fixture
def sigint_disposition():
    """Set SIGINT's handler for one test: a run started in the background by a
    non-interactive shell inherits it ignored, and Python then leaves it so."""
    previous = signal.getsignal(signal.SIGINT)

    def set_to(handler):
        signal.signal(signal.SIGINT, handler)

    yield set_to
    signal.signal(signal.SIGINT, previous)


def test_ctrl_c_during_the_fork_is_held_until_the_fork_is_done(sigint_disposition):
    sigint_disposition(signal.default_int_handler)
    process = InterruptedStart()
    with pytest.raises(KeyboardInterrupt):
        _spare._start_deferring_ctrl_c(process)
    assert process.finished  # not cut short inside the start
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_with_ctrl_c_ignored_the_fork_just_runs(sigint_disposition):
    sigint_disposition(signal.SIG_IGN)
    process = InterruptedStart()
    _spare._start_deferring_ctrl_c(process)
    assert process.finished
    assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN


def test_a_callers_own_ctrl_c_handler_gets_the_held_ctrl_c(sigint_disposition):
    seen = []
    sigint_disposition(lambda signum, frame: seen.append(signum))
    process = InterruptedStart()
    _spare._start_deferring_ctrl_c(process)
    assert process.finished and seen == [signal.SIGINT]
