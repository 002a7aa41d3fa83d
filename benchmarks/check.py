"""Wall time of a whole ``calibrator check`` of 8 poses on the simulated cell.

Run::

    .venv/bin/python benchmarks/check.py [--repeats 5] [--poses 8]

Makes a calibration once (``measure --poses 30``, ``identify``), then runs
the check as a user would, each repeat in a fresh process (interpreter start,
the D-optimal pose choice on the cell-checked planner, tracker simulator
start, the poses x 10 readings over the pty, verdict, outputs), on the arm
the calibration measured (the simulated cell's arm is drawn from ``--seed``:
the same seed); prints the median and the spread, the verdicts, and the cell
time the check estimates for a real arm.
"""

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def run(args, cwd, ok=(0,)):
    t = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "calibrator", *args], cwd=cwd, capture_output=True, text=True
    )
    elapsed = time.perf_counter() - t
    if done.returncode not in ok:
        raise SystemExit(f"calibrator {' '.join(args)} failed: {done.stderr.strip()}")
    return elapsed, done


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--poses", type=int, default=8)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        model = ["--model", "ur10e"]
        run(["measure", *model, "-q", "--seed", "3", "--poses", "30", "-o", "s.parquet"], folder)
        run(["identify", "s.parquet", "-o", "cal.json"], folder)
        times, estimate, verdicts = [], "", []
        for i in range(args.repeats):
            out = f"check{i}.json"
            elapsed, done = run(
                ["check", *model, "--calibration", "cal.json", "--seed", "3",
                 "--poses", str(args.poses), "-o", out],
                folder, ok=(0, 3, 4),
            )  # fmt: skip
            times.append(elapsed)
            estimate = next(
                line for line in done.stderr.splitlines() if line.startswith("estimated")
            )
            verdicts.append(json.loads((folder / out).read_text())["verdict"])
        print(
            f"check, {args.poses} poses x 10 readings, whole command: median "
            f"{statistics.median(times):.2f} s over {args.repeats} runs (min {min(times):.2f}, "
            f"max {max(times):.2f}); verdicts {', '.join(verdicts)}; last run's {estimate}"
        )


if __name__ == "__main__":
    main()
