"""Single readings per second through the emScon simulator and our adapter.

The simulator runs as its own process (``python -m drivers.tracker.emscon.simulator``)
and the adapter takes one stationary reading at a time over loopback TCP:
``StartMeasurement`` out, acknowledgement and a 156-byte ``SingleMeasResult``
back, exactly as in a measurement. Compare with today's line protocol
(``benchmarks/tracker_throughput.py``, same machine). Run::

    .venv/bin/python benchmarks/emscon_throughput.py [--readings 20000] [--repeats 3]
"""

from __future__ import annotations

import argparse
import sys
import time

from drivers.tracker.emscon import open_tracker
from drivers.tracker.emscon.simulator import EmsconSimulatorProcess


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--readings", type=int, default=20000, help="readings per repeat")
    parser.add_argument("--repeats", type=int, default=3, help="timed repeats (median, best)")
    args = parser.parse_args(argv)
    with EmsconSimulatorProcess(seed=1, initialised=True) as sim:
        sim.set_target([2500.0, 300.0, -200.0])
        # Generous deadlines: a loaded machine should slow the figure, not abort the run.
        tracker = open_tracker(sim.url, timeout_s=30.0, measure_timeout_s=30.0)
        try:
            tracker.connect()
            for _ in range(500):  # warm up caches and the simulator's imports
                tracker.measure()
            rates = []
            for _ in range(args.repeats):
                start = time.perf_counter()
                for _ in range(args.readings):
                    tracker.measure()
                rates.append(args.readings / (time.perf_counter() - start))
        finally:
            tracker.close()
    rates.sort()
    print(
        f"emScon single readings over 127.0.0.1 TCP: median {rates[len(rates) // 2]:.0f}/s, "
        f"best {rates[-1]:.0f}/s, worst {rates[0]:.0f}/s "
        f"({args.repeats} x {args.readings} readings)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
