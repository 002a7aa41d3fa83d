"""Wall time of a whole ``calibrator verify`` on the simulated cell (30 cycles by default).

Run::

    .venv/bin/python benchmarks/verify.py [--repeats 5] [--cycles 30]

Each repeat runs the command as a user would, in a fresh process and a fresh
temporary folder (interpreter start, test-cube search, tracker simulator
start, 5 x cycles poses of 10 readings over the pty, figures, outputs), and
prints the median and the spread. Also prints the median of the ``--calibration``
run (compensated commands) when ``--after`` is given, after one measure and
identify to make the calibration.
"""

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def timed(args, cwd):
    t = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "calibrator", *args], cwd=cwd, capture_output=True, text=True
    )
    elapsed = time.perf_counter() - t
    if done.returncode != 0:
        raise SystemExit(f"calibrator {' '.join(args)} failed: {done.stderr.strip()}")
    return elapsed


def median_of(repeats, args, folder):
    times = []
    for i in range(repeats):
        times.append(timed([*args, "-o", f"v{i}.json"], folder))
    return statistics.median(times), min(times), max(times)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--cycles", type=int, default=30)
    ap.add_argument("--after", action="store_true", help="also time a compensated run")
    args = ap.parse_args()
    base = ["verify", "-q", "--seed", "3", "--cycles", str(args.cycles)]
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        med, lo, hi = median_of(args.repeats, base, folder)
        print(
            f"verify, {args.cycles} cycles ({5 * args.cycles} poses x 10 readings), whole "
            f"command: median {med:.2f} s over {args.repeats} runs (min {lo:.2f}, max {hi:.2f})"
        )
        if args.after:
            timed(["measure", "-q", "--seed", "3", "--poses", "60", "-o", "s.parquet"], folder)
            timed(["identify", "s.parquet", "-o", "cal.json"], folder)
            after = [*base, "--calibration", "cal.json"]
            (folder / "after").mkdir()
            after[after.index("cal.json")] = str(folder / "cal.json")
            med, lo, hi = median_of(args.repeats, after, folder / "after")
            print(f"verify --calibration: median {med:.2f} s (min {lo:.2f}, max {hi:.2f})")


if __name__ == "__main__":
    main()
