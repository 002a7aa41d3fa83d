"""Estimated cell time of ordered plans against the selection order, and what ``plan`` costs.

Run::

    .venv/bin/python benchmarks/plan_order.py [--repeats 5] [--poses 30 60 100]

For each plan size, UR10e plans from three tracker positions (seeds 0..R-1):
the estimated cell time (moves at the model's caps, 0.5 s settle, 10
readings at 10 Hz) in the D-optimal selection order and in the
time-optimal, motion-checked order with its vias, and the saving. Then the
wall and CPU time of ``calibrator plan`` as a user runs it (a new process:
start-up, sampling, checks, selection, ordering, writing). Medians of the
repeats.
"""

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from calibrator import cell, planning, robots

TRACKERS = ((2500.0, 400.0, 300.0), (0.0, 2500.0, 500.0), (-2000.0, -1500.0, 800.0))


def _command_time(poses: int, seed: int, tracker: tuple, folder: Path) -> tuple[float, float]:
    """Wall and CPU (user + system of the child) time of one ``calibrator plan``, s."""
    at = ",".join(f"{v:g}" for v in tracker)
    before = os.times()
    start = time.perf_counter()
    subprocess.run(
        [sys.executable, "-m", "calibrator", "plan", "-o", folder / f"p{seed}.csv", "--force",
         "--poses", str(poses), "--tracker-at", at, "--seed", str(seed)],
        check=True, capture_output=True,
    )  # fmt: skip
    wall = time.perf_counter() - start
    after = os.times()
    return wall, (after.children_user - before.children_user) + (
        after.children_system - before.children_system
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--poses", type=int, nargs="+", default=[30, 60, 100])
    args = ap.parse_args()
    model = robots.get("ur10e")
    print("poses  selection order  ordered (vias)  saving   plan wall  plan CPU   (medians)")
    with tempfile.TemporaryDirectory() as tmp:
        for n in args.poses:
            before, after, vias, walls, cpus = [], [], [], [], []
            for seed in range(args.repeats):
                tracker = TRACKERS[seed % len(TRACKERS)]
                where = cell.Cell(tracker_at_mm=tracker)
                made = planning.make_checked(model, n, where, (0, 0, 100), seed=seed)
                before.append(made.selection_time.total_s)
                after.append(made.ordered_time.total_s)
                vias.append(made.plan.n_vias)
                wall, cpu = _command_time(n, seed, tracker, Path(tmp))
                walls.append(wall)
                cpus.append(cpu)
            b, a = statistics.median(before), statistics.median(after)
            print(
                f"{n:5d}  {b / 60:11.1f} min  {a / 60:8.1f} min ({statistics.median(vias):g})"
                f"  {100 * (b - a) / b:5.0f} %  {statistics.median(walls):7.1f} s"
                f"  {statistics.median(cpus):6.1f} s"
            )


if __name__ == "__main__":
    main()
