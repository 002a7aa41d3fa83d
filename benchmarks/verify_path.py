"""ISO 9283 path figures on the simulated cell, before and after calibration, with wall times.

Run::

    .venv/bin/python benchmarks/verify_path.py [--seed 3] [--cycles 10] [--speed 100]

Measures and identifies the hidden arm of ``--seed`` once (60 poses), then
runs ``calibrator verify --path line|circle|rectangle`` with nominal and with
compensated commands, each in a fresh process as a user would, and prints
AT_P, RT_P, AV, FV (and the worst CR and CO of the rectangle) with the
wall time of each command.
"""

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def run(args, cwd):
    t = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "calibrator", *args], cwd=cwd, capture_output=True, text=True
    )
    if done.returncode != 0:
        raise SystemExit(f"calibrator {' '.join(args)} failed: {done.stderr.strip()}")
    return time.perf_counter() - t


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", default="3")
    parser.add_argument("--cycles", default="10")
    parser.add_argument("--speed", default="100", help="path speed, mm/s")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        run(["measure", "-q", "--seed", args.seed, "--poses", "60", "-o", "s.parquet"], folder)
        run(["identify", "s.parquet", "-o", "cal.json"], folder)
        common = ["--seed", args.seed, "--cycles", args.cycles, "--path-speed", args.speed]
        print(f"seed {args.seed}, {args.cycles} cycles at {args.speed} mm/s")
        print("path       commands      AT_P mm   RT_P mm    AV %    FV mm/s  CR/CO max mm   s")
        for shape in ("line", "circle", "rectangle"):
            for label, extra in (("nominal", []), ("compensated", ["--calibration", "cal.json"])):
                out = f"{shape}-{label}.json"
                wall = run(["verify", "--path", shape, *common, *extra, "-o", out], folder)
                p = json.loads((folder / out).read_text())["path"]
                corners = f"{max(p['CR_mm']):.3f}/{max(p['CO_mm']):.3f}" if "CR_mm" in p else "-"
                print(
                    f"{shape:10} {label:12} {p['AT_P_mm']:8.4f}  {p['RT_P_mm']:8.4f}  "
                    f"{p['AV_pct']:+6.3f}  {p['FV_mm_s']:7.3f}  {corners:>13}  {wall:5.1f}"
                )


if __name__ == "__main__":
    sys.exit(main())
