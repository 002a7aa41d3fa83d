"""Soak test of the tracker link: many readings over a pty, injected reconnects and late replies.

The simulator runs as its own process behind a pty. The driver takes
``--readings`` single readings; at ``--injections`` evenly spaced points
a MEAS reply is delayed by 0.3 s and either

- the port fails while that MEAS waits (a ``SerialException``, as when a
  USB adapter drops out), so the driver reconnects and the late reply
  arrives on the new link; or
- the call times out first (``timeout_s=0.1``), and the late reply arrives
  while the next MEAS waits.

Either way the late reply must be dropped and counted, never returned: the
target moves after each injection, and every reading returned is checked
against the target of its own pose. Driver memory (RSS and Python's
allocated blocks) is taken after a warm-up and at the end. Run::

    .venv/bin/python benchmarks/tracker_soak.py [--readings 100000] [--injections 10]

Exit status 1 if a late reply was returned, a late reply was not counted,
or memory grew.
"""

from __future__ import annotations

import argparse
import gc
import os
import sys
import time

import numpy as np
import serial

from drivers.tracker import ConnectionLost, LaserTracker, TrackerTimeout
from drivers.tracker.line.simulator import SimulatorProcess

LATE_S = 0.3  # how late the injected reply comes
TOLERANCE_MM = 1.0  # a reading of another pose is >= 100 mm off; noise is ~0.01 mm
MAX_RSS_GROWTH_KIB = 1024
MAX_BLOCK_GROWTH = 2000


class FlakyPort(serial.Serial):
    """A real pyserial port on the pty whose next read can be made to fail once."""

    fail_next_read = False

    def read(self, size: int = 1) -> bytes:
        if self.fail_next_read:
            self.fail_next_read = False
            raise serial.SerialException("injected: device disconnected")
        return super().read(size)


def rss_kib() -> int:
    """Resident set size of this process, KiB (Linux)."""
    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") // 1024


def memory() -> tuple[int, int]:
    gc.collect()
    return rss_kib(), sys.getallocatedblocks()


def target(k: int) -> np.ndarray:
    """True point of pose ``k``, mm: poses 100 mm apart so a stale reading cannot pass."""
    return np.array([2500.0 + 100.0 * (k % 20), 300.0 - 50.0 * (k % 7), -200.0])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--readings", type=int, default=100_000)
    parser.add_argument("--injections", type=int, default=10, help="late replies injected")
    parser.add_argument("--warmup", type=int, default=2000)
    args = parser.parse_args(argv)

    inject_at = set(np.linspace(0, args.readings, args.injections + 2)[1:-1].astype(int))
    wrong = reconnects = timeouts = 0
    with SimulatorProcess(seed=1, initialised=True) as sim:
        port = FlakyPort(sim.url, timeout=10.0)
        pose = 0
        sim.set_target(target(pose))
        with LaserTracker(
            port, timeout_s=10.0, measure_timeout_s=10.0, reconnect_delay_s=0.05
        ) as tracker:
            tracker.connect()
            for _ in range(args.warmup):
                tracker.measure()
            rss0, blocks0 = memory()
            stale0 = tracker.stale_replies
            started = time.perf_counter()
            for i in range(args.readings):
                if i in inject_at:
                    sim.arm_fault(f"MEAS+1 delay delay={LATE_S}")
                    if (reconnects + timeouts) % 2 == 0:  # alternate the two kinds
                        port.fail_next_read = True
                        try:
                            tracker.measure()
                        except ConnectionLost:
                            reconnects += 1
                    else:
                        try:
                            tracker.measure(timeout_s=0.1)
                        except TrackerTimeout:
                            timeouts += 1
                    pose += 1
                    sim.set_target(target(pose))  # the late reply holds the old pose's point
                    continue
                reading = tracker.measure()
                if np.linalg.norm(reading.point_mm - target(pose)) > TOLERANCE_MM:
                    wrong += 1
            elapsed = time.perf_counter() - started
            rss1, blocks1 = memory()
            stale = tracker.stale_replies - stale0
            link_buffer = len(tracker.link._buf)
        port.close()

    injected = reconnects + timeouts
    print(
        f"{args.readings} readings over a pty in {elapsed:.1f} s "
        f"({args.readings / elapsed:.0f}/s including {injected} injections)"
    )
    print(
        f"injected late replies: {injected} ({reconnects} with a reconnect, {timeouts} "
        f"after a timeout); dropped and counted: {stale}; readings of another pose returned: "
        f"{wrong}"
    )
    print(
        f"driver memory: RSS {rss0} -> {rss1} KiB ({rss1 - rss0:+d}), Python blocks "
        f"{blocks0} -> {blocks1} ({blocks1 - blocks0:+d}); link buffer {link_buffer} bytes"
    )
    ok = (
        wrong == 0
        and stale == injected == args.injections
        and rss1 - rss0 <= MAX_RSS_GROWTH_KIB
        and blocks1 - blocks0 <= MAX_BLOCK_GROWTH
    )
    print("PASS" if ok else "FAIL")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
