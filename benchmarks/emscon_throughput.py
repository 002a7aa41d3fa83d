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

from _readings import readings_per_second

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
            rates = readings_per_second(tracker, args.readings, args.repeats)
        finally:
            tracker.close()
    print(
        f"emScon single readings over 127.0.0.1 TCP: median {rates[len(rates) // 2]:.0f}/s, "
        f"best {rates[-1]:.0f}/s, worst {rates[0]:.0f}/s "
        f"({args.repeats} x {args.readings} readings)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
