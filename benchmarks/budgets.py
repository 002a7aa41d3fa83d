"""What the budgets of ``calibrator.cli._checks.BUDGETS`` bound: time and memory per unit.

Runs each budgeted command at a small size in a fresh process, several
times, and prints the median wall time and peak memory, scaled to one unit
(per candidate, per trial, per pose x sample). Multiply by a limit to see
what the limit allows::

    python benchmarks/budgets.py [--repeats 3]
"""

import argparse
import statistics
import subprocess
import sys
import tempfile
import time

CASES = {
    # name: (arguments, units, unit name)
    "plan d-optimal": (
        ["plan", "--model", "ur10e", "--poses", "30", "--candidates", "20000", "-o", "p.csv"],
        30 * 20000,
        "pose x candidate",
    ),
    "analyze misalignment": (
        ["analyze", "misalignment", "-q", "--trials", "100000"],
        100000,
        "trial",
    ),
    "analyze tolerance": (
        ["analyze", "tolerance", "--model", "ur10e", "--poses", "200", "--samples", "5000"],
        200 * 5000,
        "pose x sample",
    ),
}


#: Runs the command in the child and reports the child's own peak memory (kB) on stderr.
_CHILD = (
    "import resource, sys\n"
    "from calibrator.cli import main\n"
    "try:\n"
    "    main(sys.argv[1:])\n"
    "except SystemExit as exc:\n"
    "    assert not exc.code, exc.code\n"
    "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, file=sys.stderr)\n"
)


def run(args, folder):
    """Wall time (s) and peak memory (bytes) of one command in a fresh process."""
    start = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-c", _CHILD, *args],
        cwd=folder,
        check=True,
        capture_output=True,
        text=True,
    )
    elapsed = time.perf_counter() - start
    return elapsed, int(done.stderr.strip().splitlines()[-1]) * 1024


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    options = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        for name, (args, units, unit) in CASES.items():
            runs = [run(args, folder) for _ in range(options.repeats)]
            seconds = statistics.median(r[0] for r in runs)
            peak = max(r[1] for r in runs)
            print(
                f"{name:22s} median {seconds:7.2f} s, peak {peak / 2**20:7.0f} MB; "
                f"{1e6 * seconds / units:8.3f} us and {peak / units:8.1f} B per {unit}"
            )


if __name__ == "__main__":
    main()
