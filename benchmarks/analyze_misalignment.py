"""Speed and memory of the misalignment Monte Carlo (paper arm, R0 = 0.05 mm).

Run::

    nice .venv/bin/python benchmarks/analyze_misalignment.py [--repeats 5] [--big 10000000]
        [--rounds 1] [--workers-only]

1. 20,000 trials in-process (``engine.run`` + ``statistics``, the grid's
   pilot block included): median wall time of ``--repeats`` runs.
2. 1,000,000 trials in-process in a fresh process: wall time and peak
   resident memory (``ru_maxrss``), next to the same process running 10,000
   trials (interpreter + imports + one block) as the baseline.
3. ``--big`` trials (10^7 by default) in-process and on a Dask LocalCluster
   of 1 and of 2 single-threaded worker processes (cluster start-up
   included): wall times, one worker against in-process, and the speed-up;
   the statistics must be identical, to the bit.

With ``--cli``, part 3 times the whole command as a user runs it instead
(``calibrator analyze misalignment --trials BIG -q --json F [--workers N]``,
a new process each, the three settings alternating), with CPU time, and
compares the JSON statistics the three wrote. ``--against DIR`` (with
``--cli``) runs the same commands on another copy of the code too (DIR
first on ``PYTHONPATH``, e.g. ``git archive COMMIT | tar -x -C DIR``),
alternating with this one, and prints both sets of figures and their ratio.
"""

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from calibrator.analysis import arm, engine
from calibrator.analysis import misalignment as mc

_CHILD = """
import json, resource, sys, time
from calibrator.analysis import arm, engine, misalignment as mc
trials = int(sys.argv[1])
t = time.perf_counter()
summary, grid = engine.run(mc.Study(arm.build(), 0.05, mc.PAPER_H_MM, trials, 0))
mc.statistics(summary, grid)
wall = time.perf_counter() - t
rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(json.dumps({"wall": wall, "maxrss_mb": rss}))
"""


def study(trials):
    return mc.Study(arm.build(), 0.05, mc.PAPER_H_MM, trials, seed=0)


def timed(trials, **kwargs):
    t = time.perf_counter()
    summary, grid = engine.run(study(trials), **kwargs)
    stats = mc.statistics(summary, grid)
    return time.perf_counter() - t, stats


def child(trials):
    out = subprocess.run(
        [sys.executable, "-c", _CHILD, str(trials)], check=True, capture_output=True, text=True
    )
    return json.loads(out.stdout)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--big", type=int, default=10_000_000)
    ap.add_argument("--rounds", type=int, default=1, help="Alternate 1 and 2 workers this often.")
    ap.add_argument("--workers-only", action="store_true", help="Only the 1-vs-2 worker part.")
    ap.add_argument("--cli", action="store_true", help="Time whole CLI processes in part 3.")
    ap.add_argument(
        "--against", metavar="DIR", help="With --cli: also time the code in DIR, alternating."
    )
    args = ap.parse_args()
    if args.against and not args.cli:
        ap.error("--against needs --cli")
    if not args.workers_only:
        in_process(args)
    (workers_cli if args.cli else workers)(args)


def in_process(args):
    times = [timed(20_000)[0] for _ in range(args.repeats)]
    print(
        f"20,000 trials in-process: median {statistics.median(times):.3f} s "
        f"(min {min(times):.3f}, max {max(times):.3f}, {args.repeats} runs)"
    )

    base = child(10_000)
    big = child(1_000_000)
    print(
        f"1,000,000 trials in-process: {big['wall']:.2f} s, peak RSS {big['maxrss_mb']:.0f} MB "
        f"(10,000 trials in the same kind of process: {base['maxrss_mb']:.0f} MB)"
    )


def workers(args):
    """Part 3 through ``engine.run`` in this process (imports paid once, before)."""

    def run(n, _variant):
        wall, stats = timed(args.big, workers=n or None)
        return wall, None, stats

    alternate(args, run, ["engine.run"])


def workers_cli(args):
    """Part 3 as whole ``calibrator analyze misalignment`` processes (this code, and DIR's)."""
    paths = {"this code": None}
    if args.against:
        paths["DIR's code"] = str(Path(args.against).resolve())
    with tempfile.TemporaryDirectory() as tmp:

        def env_of(variant):
            path = paths[variant]
            return dict(os.environ, **({"PYTHONPATH": path} if path else {}))

        def run(n, variant):
            out = Path(tmp) / f"w{n}.json"
            out.unlink(missing_ok=True)  # the command never overwrites without --force
            command = [sys.executable, "-m", "calibrator", "analyze", "misalignment"]
            command += ["--trials", str(args.big), "-q", "--json", str(out)]
            command += ["--workers", str(n)] if n else []
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            t = time.perf_counter()
            # From the temporary folder: ``-m`` puts the working folder first on the path,
            # where this project's copy would shadow DIR's.
            subprocess.run(command, check=True, capture_output=True, env=env_of(variant), cwd=tmp)
            wall = time.perf_counter() - t
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            # Workers included: the command reaps them, so their time is its children's.
            cpu = after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime
            return wall, cpu, json.loads(out.read_text())

        for variant in paths:
            where = subprocess.run(
                [sys.executable, "-c", "import calibrator; print(calibrator.__file__)"],
                check=True, capture_output=True, text=True, env=env_of(variant), cwd=tmp,
            )  # fmt: skip
            print(f"{variant}: {where.stdout.strip()}")
        medians = alternate(args, run, list(paths))
    if args.against:
        this, theirs = medians["this code"], medians["DIR's code"]
        print(
            "this code / DIR's, medians: "
            + ", ".join(f"{label} {this[n] / theirs[n]:.3f}" for n, label in SETTINGS)
        )


#: In-process, one worker, two workers.
SETTINGS = ((0, "in-process"), (1, "1 worker"), (2, "2 workers"))


def alternate(args, run, variants):
    """Every setting of every variant in turn, ``--rounds`` times; print medians and ratios.

    ``run(n, variant)`` -> ``(wall s, CPU s or None, statistics)``. Returns
    ``{variant: {n: median wall}}``.
    """
    # Alternating spreads drifts in the machine's load over all settings and variants.
    times = {(v, n): [] for v in variants for n, _ in SETTINGS}
    cpus = {(v, n): [] for v in variants for n, _ in SETTINGS}
    results = []
    for _ in range(args.rounds):
        for n, label in SETTINGS:
            for v in variants:
                wall, cpu, stats = run(n, v)
                times[v, n].append(wall)
                cpus[v, n].append(cpu)
                results.append(stats)
                print(f"{args.big:,} trials, {v}, {label}: {wall:.2f} s wall", flush=True)
    medians = {}
    for v in variants:
        here, one, two = (statistics.median(times[v, n]) for n, _ in SETTINGS)
        medians[v] = {0: here, 1: one, 2: two}
        line = (
            f"{v}: medians over {args.rounds} round(s): in-process {here:.2f} s, "
            f"1 worker {one:.2f} s, 2 workers {two:.2f} s; 1 worker / in-process: "
            f"{one / here:.2f}x; 2 workers faster than 1: {one / two:.2f}x"
        )
        if cpus[v, 0][0] is not None:
            line += "; CPU medians " + ", ".join(
                f"{statistics.median(cpus[v, n]):.2f} s" for n, _ in SETTINGS
            )
        print(line)
    print(
        f"statistics identical in all {len(results)} runs: {all(r == results[0] for r in results)}"
    )
    return medians


if __name__ == "__main__":
    main()
