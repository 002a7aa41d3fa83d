"""``calibrator identify`` wall time and peak memory against the pose count.

Run::

    .venv/bin/python benchmarks/identify_scaling.py [--poses 30 300 3000 10000] [--repeats 3]

For each pose count, simulates the default session (ER10L-C10, the IPSO paper's errors,
orientation, 0.02 mm noise) into a temporary folder, then runs the whole
command as a user does (a new process: start-up, load, identify with the
defaults, hybrid + lsq, write). Reports the median wall time, the median
CPU time (user + system: on a machine shared with other work, the figure
that load does not inflate) and the largest peak resident memory of the
process (``ru_maxrss`` from ``wait4``).
"""

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CLI = [sys.executable, "-m", "calibrator"]


def run(args):
    """Wall time (s), CPU time (s) and peak RSS (MB) of one command."""
    t = time.perf_counter()
    proc = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    elapsed = time.perf_counter() - t
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"{' '.join(map(str, args))} failed: {proc.stderr.read().decode()}")
    return elapsed, usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024.0


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--poses", type=int, nargs="+", default=[30, 300, 3000, 10000])
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    print(f"{'poses':>8s}{'median s':>10s}{'min s':>8s}{'CPU s':>8s}{'peak MB':>9s}")
    with tempfile.TemporaryDirectory() as tmp:
        for n in args.poses:
            session = Path(tmp) / f"s{n}.parquet"
            subprocess.run(
                [*CLI, "simulate", "-o", session, "--poses", str(n)],
                check=True,
                capture_output=True,
            )
            rows = [
                run([*CLI, "identify", session, "-o", Path(tmp) / "c.json", "--force"])
                for _ in range(args.repeats)
            ]
            times = [r[0] for r in rows]
            cpu = statistics.median(r[1] for r in rows)
            print(
                f"{n:8d}{statistics.median(times):10.2f}{min(times):8.2f}{cpu:8.2f}"
                f"{max(r[2] for r in rows):9.0f}"
            )
        bare = run([sys.executable, "-c", "pass"])
        print(f"bare interpreter start: {bare[0]:.2f} s, {bare[2]:.0f} MB")


if __name__ == "__main__":
    main()
