"""Single readings per second through the full tracker protocol over a pty.

The simulator runs as its own process (``python -m drivers.tracker.line.simulator
--pty``) and the driver takes one ``MEAS`` at a time: frame, CRC, write,
read, check, parse, exactly as in a measurement. Run::

    .venv/bin/python benchmarks/tracker_throughput.py [--readings 20000] [--repeats 3]

Target on a 2-core machine: >= 2000 single readings/s.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

from _readings import readings_per_second

from drivers.tracker import LaserTracker

REPO = Path(__file__).resolve().parents[1]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--readings", type=int, default=20000, help="readings per repeat")
    parser.add_argument("--repeats", type=int, default=3, help="timed repeats (best and median)")
    parser.add_argument("--tcp", action="store_true", help="use socket://127.0.0.1 instead")
    args = parser.parse_args(argv)
    endpoint = ["--tcp", "0"] if args.tcp else ["--pty"]
    sim = subprocess.Popen(
        [sys.executable, "-m", "drivers.tracker.line.simulator", *endpoint, "--initialised",
         "--target", "2500,300,-200", "--seed", "1"],
        cwd=REPO, stdout=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        line = sim.stdout.readline().strip()
        url = f"socket://127.0.0.1:{line}" if args.tcp else line
        # Generous deadlines: a loaded machine should slow the figure, not abort the run.
        with LaserTracker(url, timeout_s=30.0, measure_timeout_s=30.0) as tracker:
            tracker.connect()
            rates = readings_per_second(tracker, args.readings, args.repeats)
    finally:
        sim.terminate()
        sim.wait(timeout=5)
    transport = "socket://127.0.0.1" if args.tcp else "pty"
    print(
        f"tracker single readings over {transport}: median {rates[len(rates) // 2]:.0f}/s, "
        f"best {rates[-1]:.0f}/s, worst {rates[0]:.0f}/s "
        f"({args.repeats} x {args.readings} readings)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
