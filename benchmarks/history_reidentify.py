"""Acceptance check M2: ``history reidentify`` of 200 stored sessions on 1 and on 2 Dask workers.

Run::

    .venv/bin/python benchmarks/history_reidentify.py [--sessions 200] [--repeats 1]

Simulates SESSIONS sessions of one arm (seeds 0.., 32 poses each) and
records them in an SQLite history; then runs ``calibrator history
reidentify --workers 1`` and ``--workers 2`` as a user would (fresh
processes, identify's default options: the swarm then least squares), and
prints each wall time and the ratio. Also checks that the two runs wrote the
same calibrations, byte for byte but their ``created`` time, and that a
few equal ``calibrator identify`` run on those sessions one by one.
"""

import argparse
import json
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from calibrator import session, simulate
from calibrator.history import open_history


def _calibrator(*args, cwd):
    """Run calibrator; return its wall time and the CPU time of it and its workers (s)."""
    cpu = _children_cpu()
    started = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "calibrator", *map(str, args)], cwd=cwd, capture_output=True,
        text=True,
    )  # fmt: skip
    if done.returncode != 0:
        raise SystemExit(f"calibrator {' '.join(map(str, args))} failed: {done.stderr.strip()}")
    return time.perf_counter() - started, _children_cpu() - cpu


def _children_cpu():
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _doc(path):
    doc = json.loads(Path(path).read_text())
    del doc["created"]
    return doc


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sessions", type=int, default=200)
    parser.add_argument("--repeats", type=int, default=1)
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp(prefix="history-reidentify-"))
    try:
        history = folder / "h.sqlite"
        with open_history(history) as h:
            for seed in range(args.sessions):
                path = folder / f"s{seed:03d}.parquet"
                table, meta, _ = simulate.simulate(seed=seed, noise_mm=0.02)
                session.write(path, table, meta)
                h.record_session(path, robot="arm-1")
        times = {1: [], 2: []}
        for r in range(args.repeats):
            for workers in (1, 2):
                out = folder / f"w{workers}-{r}"
                wall, cpu = _calibrator(
                    "history", "reidentify", "--history", history, "-o", out,
                    "--workers", workers, "-q", cwd=folder,
                )  # fmt: skip
                times[workers].append(wall)
                # CPU / wall: how many cores the run had (2 workers on an idle 2-core machine: ~2).
                print(f"{workers} worker(s): {wall:.1f} s, {cpu / wall:.2f} cores busy", flush=True)
        one, two = sorted(folder.glob("w1-0/*.json")), sorted(folder.glob("w2-0/*.json"))
        assert len(one) == len(two) == args.sessions
        assert all(_doc(a) == _doc(b) for a, b in zip(one, two, strict=True))
        for path in one[:3]:
            source = folder / (path.stem.rsplit("-", 1)[0] + ".parquet")
            _calibrator("identify", source, "-o", folder / "one.json", "-q", cwd=folder)
            assert _doc(folder / "one.json") == _doc(path), path
            (folder / "one.json").unlink()
        best1, best2 = min(times[1]), min(times[2])
        print(
            f"{args.sessions} sessions: 1 worker {best1:.1f} s, 2 workers {best2:.1f} s, "
            f"{best1 / best2:.2f}x; results identical (and to identify on 3 of them)"
        )
    finally:
        shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    main()
