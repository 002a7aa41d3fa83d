"""Wall time of ``calibrator identify`` on a 30-pose session, start-up included.

Run::

    .venv/bin/python benchmarks/identify_cli.py [--repeats 7]

Simulates the seed 003 robot (30 poses, orientation, 0.02 mm noise) into a
temporary folder, then times the whole command as a user runs it (a new
process each time: interpreter start, imports, load, IPSO 20 x 2000, least
squares, report, write).
"""

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CLI = [sys.executable, "-m", "calibrator"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        session = Path(tmp) / "session.parquet"
        subprocess.run(
            [*CLI, "simulate", "-o", session, "--poses", "30"], check=True, capture_output=True
        )
        times = []
        for _ in range(args.repeats):
            t = time.perf_counter()
            subprocess.run(
                [*CLI, "identify", session, "-o", Path(tmp) / "cal.json"],
                check=True,
                capture_output=True,
            )
            times.append(time.perf_counter() - t)
        t = time.perf_counter()
        subprocess.run([sys.executable, "-c", "pass"], check=True)
        bare = time.perf_counter() - t
    print(
        f"calibrator identify, 30 poses, hybrid 20 x 2000: median {statistics.median(times):.2f} s,"
        f" min {min(times):.2f} s, max {max(times):.2f} s over {args.repeats} runs"
        f" (bare interpreter start {bare:.2f} s)"
    )


if __name__ == "__main__":
    main()
