"""Wall time of ``calibrator measure`` on the simulated wire: 30 poses x 10 readings, zero settle.

Run::

    .venv/bin/python benchmarks/measure.py [--repeats 7] [--poses 30] [--make-plan]

Each run is a new process as a user starts it (interpreter, imports, the
tracker simulator started as a child process behind a real pty, the plan
read and checked against the arm and the cell, 300 readings over the wire,
journal fsyncs, Parquet write). The plan is made once beforehand with
``calibrator plan`` (its own benchmark is plan_order.py); ``--make-plan``
times ``measure --poses N`` instead, which makes and orders the plan in the
run. Prints the median
wall time, readings per second (whole command and measure loop alone), and
the median of each phase that ``measure --timings`` reports.
"""

import argparse
import re
import statistics
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

CLI = [sys.executable, "-m", "calibrator"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--poses", type=int, default=30)
    ap.add_argument("--readings", type=int, default=10)
    ap.add_argument("--make-plan", action="store_true", help="time measure --poses N")
    args = ap.parse_args()
    walls, phases = [], defaultdict(list)
    with tempfile.TemporaryDirectory() as tmp:
        plan = ["--poses", str(args.poses)]
        if not args.make_plan:
            from calibrator.simulate import SimWorld

            at = ",".join(f"{v:.3f}" for v in SimWorld.make("ur10e", 0).tracker_at_mm)
            plan_csv = Path(tmp) / "plan.csv"
            subprocess.run(
                [*CLI, "plan", "--poses", str(args.poses), "--tracker-at", at, "-o", plan_csv],
                check=True,
                capture_output=True,
            )
            plan = ["--plan", str(plan_csv)]
        for i in range(args.repeats):
            out = Path(tmp) / f"s{i}.parquet"
            t = time.perf_counter()
            done = subprocess.run(
                [*CLI, "measure", *plan, "--readings", str(args.readings)]
                + ["--settle", "0", "--timings", "-o", str(out)],
                check=True,
                capture_output=True,
                text=True,
            )
            walls.append(time.perf_counter() - t)
            for what, seconds in re.findall(r"timing: (.+): ([0-9.]+) s", done.stderr):
                phases[what].append(float(seconds))
    n = args.poses * args.readings
    wall = statistics.median(walls)
    loop = statistics.median(phases["measure loop"])
    print(
        f"measure {args.poses} poses x {args.readings} readings, {args.repeats} runs: "
        f"median {wall:.2f} s wall (min {min(walls):.2f}, max {max(walls):.2f}), "
        f"{n / wall:.0f} readings/s overall, {n / loop:.0f} readings/s in the loop"
    )
    accounted = 0.0
    for what, values in phases.items():
        accounted += statistics.median(values)
        print(f"  {what:36s} {statistics.median(values):.3f} s")
    print(f"  {'interpreter start, imports, exit':36s} {wall - accounted:.3f} s (the rest)")


if __name__ == "__main__":
    main()
