"""Wall time of ``calibrator identify`` on a 30-pose session, start-up included.

Run::

    .venv/bin/python benchmarks/identify_cli.py [--repeats 7]

Simulates the IPSO paper's robot (30 poses, orientation, 0.02 mm noise) into a
temporary folder, then times the whole command as a user runs it (a new
process each time: interpreter start, imports, load, IPSO 20 x 2000, least
squares, report, write). Reports wall time and CPU time (user + system of
the process: on a machine shared with other work, the figure that load does
not inflate).

The least squares is :mod:`calibrator.identify.levmar` (numpy), so the run
imports nothing from scipy: ``python -X importtime -m calibrator identify
S.parquet -o c.json 2>&1 | grep scipy`` prints nothing. Compare against
another checkout by running this script with that checkout's interpreter.
With ``PYTHONDONTWRITEBYTECODE`` set (and no ``__pycache__`` yet), every run
also compiles the project's sources, a few hundredths of a second of CPU a
user with cached bytecode does not pay: the script says which case it measured.
"""

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from identify_scaling import run  # noqa: I001 - the sibling benchmark script

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
        rows = [
            run([*CLI, "identify", session, "-o", Path(tmp) / "cal.json", "--force"])
            for _ in range(args.repeats)
        ]
        bare = run([sys.executable, "-c", "pass"])
    times, cpu = [r[0] for r in rows], [r[1] for r in rows]
    print(
        f"calibrator identify, 30 poses, hybrid 20 x 2000: median {statistics.median(times):.2f} s,"
        f" min {min(times):.2f} s, max {max(times):.2f} s over {args.repeats} runs;"
        f" CPU median {statistics.median(cpu):.2f} s, min {min(cpu):.2f} s"
        f" (bare interpreter start {bare[0]:.2f} s;"
        f" bytecode {'not written' if os.environ.get('PYTHONDONTWRITEBYTECODE') else 'cached'})"
    )


if __name__ == "__main__":
    main()
